"""The UAV delivery scenario (docs/delivery-model.md, docs/delivery-experiments.md Figures 16-20): a fleet of UAVs
bids for orders, flies them and recharges; each UAV's policy learns which attempts succeed.

``scenario`` (the :mod:`dronefleet.scenarios` adaptor), ``simulation`` (one run),
``engine`` (the compiled event loop), ``records`` (a run's tables), ``metrics``,
``analysis`` and ``figures`` (the figure tables and drawings), ``bench``. Nothing is
imported here, so importing one delivery module loads numba or pandas only if it needs them.
"""
