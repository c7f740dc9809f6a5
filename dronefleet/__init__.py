"""dronefleet: event-driven simulator of on-demand parcel delivery by UAV fleets.

The model is ``MODEL.md`` of the study; the tree follows its domain:
orders, energy, policy, auction, supervisor, engine, records, config, cli.
"""

__version__ = "0.1.0"
