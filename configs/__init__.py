"""The shipped configs, installed as the package ``dronefleet.configs`` (see pyproject.toml):
``paper.toml``, ``reference-code.toml``, ``replenishment.toml`` and the sweep files of
``sweeps/``. Code finds them with :func:`dronefleet.config.shipped_config`."""
