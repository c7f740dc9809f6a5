"""The UAV delivery scenario (MODEL.md, EXPERIMENTS.md Figures 16-20): a fleet of UAVs
bids for orders, flies them and recharges; the policy learns which attempts succeed.

``scenario`` (the :mod:`dronefleet.scenarios` adaptor), ``simulation`` (one run),
``engine`` (the compiled kernel), ``records``-shaped tables, ``metrics``, ``analysis``
and ``figures`` (the figure tables and drawings). Nothing is imported here, so that
importing a delivery module does not load numba or pandas before it is needed.
"""
