"""What the replay page (:mod:`dronefleet.replay`) shows of a replenishment run: one of its trials.

A run's tables hold per-trial totals and phase counts, not where the robots were, so the
trial (the first, or ``replay --trial K``) is simulated again, alone, with the kernel's track
switched on (a trial's outcome does not depend on the trials beside it, so this is exactly the
trial of the run):
every robot's centre, battery and controller phase at each sample of the time series.
"""

import dataclasses
import math
from typing import Any

import numpy as np

from .kernel import DT, PHASES, RADIUS, TS_STORED, TS_WORK, WALL

__all__ = ["replay_data", "AREAS", "MAX_FRAMES"]

#: The floor's coloured areas, as :func:`dronefleet.replenishment.kernel.floor_colour` reads
#: them: ``[x_min, x_max, y_min, y_max]`` [m]; the transfer area only with mobile chargers.
AREAS = {"base": [-0.825, -0.5, -0.825, 0.825], "transfer": [0.2, 0.5, -0.825, 0.825],
         "work": [0.5, 0.825, -0.825, 0.825]}
#: At most this many frames in the page: a longer run keeps every k-th sample (and only
#: those are simulated: the track of every sample of a long run would not fit in memory).
MAX_FRAMES = 20_000


def replay_data(config: Any, description: str, trial: int) -> dict[str, Any]:
    """The page's data of trial ``trial`` of a replenishment run of ``config`` (a
    :class:`dronefleet.replenishment.config.Config`, described as ``description``).

    Returns a JSON-ready dict: ``title``, ``duration_s`` (ticks x 0.1 s), ``frame_s`` (time
    between frames [s]), ``n_workers``, ``n_chargers``, ``capacity`` (per robot [energy
    units]), ``wall_m``, ``radius_m``, ``areas`` (:data:`AREAS`), ``phases`` (names per role);
    per frame (robot-major within a frame): ``x``, ``y`` [m], ``energy`` [energy units],
    ``phase``; and per frame ``work`` (cumulative points) and ``stored`` (energy in all
    batteries).
    """
    from .simulate import simulate

    p = config.params
    stride = math.ceil((p.ticks // p.sample_every + 1) / MAX_FRAMES)
    # sampling only reads the state: every stride-th sample of the run, and no other
    r = simulate(dataclasses.replace(p, sample_every=p.sample_every * stride), trials=1,
                 first_trial=trial, track=True)
    track = r["track"]
    areas = AREAS if p.mobile else {name: area for name, area in AREAS.items() if name != "transfer"}
    return {
        "scenario": "replenishment",
        "title": f"replenishment run, trial {trial} of: {description}",
        "duration_s": p.ticks * DT,
        "frame_s": p.sample_every * stride * DT,
        "n_workers": p.n_workers,
        "n_chargers": p.n_chargers,
        "capacity": [p.worker_capacity] * p.n_workers + [p.charger_capacity] * p.n_chargers,
        "wall_m": WALL,
        "radius_m": RADIUS,
        "areas": areas,
        "phases": {"workers": list(PHASES["workers"]), "chargers": list(PHASES["chargers"])},
        "x": np.round(track["x"], 4).reshape(-1).tolist(),
        "y": np.round(track["y"], 4).reshape(-1).tolist(),
        "energy": np.round(track["energy"], 2).reshape(-1).tolist(),
        "phase": track["phase"].reshape(-1).tolist(),
        "work": r["series"][0, :, TS_WORK].astype(np.int64).tolist(),
        "stored": np.round(r["series"][0, :, TS_STORED], 1).tolist(),
    }
