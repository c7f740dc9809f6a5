"""Run one configuration of the lunar model: all its runs in one kernel call, as pyarrow tables.

:func:`simulate` returns the tables of the contract (``summary``, ``timeseries``, ``trips``,
``snapshots``); :func:`table_schemas` gives their columns and types. Run j draws its per-robot
streams from ``seed * 2**32 + j`` whatever the layout or options (spec section 13), so run j of
every scenario is paired with run j of every other.
"""

from __future__ import annotations

import pyarrow as pa

from .params import LunarParams

__all__ = ["simulate", "table_schemas", "TABLES"]

TABLES = ("summary", "timeseries", "trips", "snapshots")
_I, _F, _S = pa.int64(), pa.float64(), pa.string()
ROW_NAMES = tuple(f"row{r}" for r in range(1, 12)) + ("rowD",)

_SUMMARY = (
    [("run", _I), ("seed", _I), ("layout", _S), ("battery_wh", _F), ("resources", _I), ("trips", _I),
     ("interruptions", _I), ("nest_recharges", _I), ("sessions", _I), ("deaths", _I), ("beacons", _I),
     ("mobile", _I), ("units_beacons", _I),
     ("alignment_T", _F), ("alignment_N", _F), ("alignment_R", _F),
     ("alignment_w_T", _F), ("alignment_w_N", _F), ("alignment_w_R", _F),
     ("heading_alignment_T", _F), ("heading_alignment_N", _F), ("heading_alignment_R", _F),
     ("deaths_per_session", _F), ("t_first_T", _F), ("t_first_R", _F), ("t_first_row5", _F),
     ("t_beacons_90", _F)]
    + [(name, _I) for name in ROW_NAMES])
_TIMESERIES = [
    ("run", _I), ("t", _F), ("resources", _I), ("trips", _I), ("interruptions", _I),
    ("nest_recharges", _I), ("sessions", _I), ("rate", _F), ("n_mobile", _I), ("n_beacons", _I),
    ("n_dead", _I), ("n_unspawned", _I), ("n_f_out", _I), ("n_f_in", _I), ("n_r", _I),
    ("soc_sum", _F), ("soc_beacons", _F), ("soc_mobile", _F), ("soc_min_beacon", _F),
    ("units_beacons", _I), ("alignment_T", _F), ("alignment_N", _F), ("alignment_R", _F)]
_TRIPS = [
    ("run", _I), ("origin", _S), ("dest", _S), ("tick_left", _I), ("tick_entered", _I),
    ("length_m", _F), ("energy_j", _F), ("energy_wh", _F), ("soc_cost", _F), ("duration_s", _F),
    ("soft_length_m", _F), ("role_left", _S), ("role_entered", _S), ("robot", _I)]
_SNAPSHOTS = (
    [("run", _I), ("label", _S), ("t", _F), ("robot", _I), ("status", _S), ("role", _S), ("mode", _S),
     ("x", _F), ("y", _F), ("heading", _F), ("soc", _F), ("load", _I)]
    + [(f"{q}_{r}", _F) for q in ("omega", "vx", "vy", "S") for r in ("T", "N", "R")])


def table_schemas() -> dict[str, pa.Schema]:
    """``{table: pyarrow.Schema}`` of the tables :func:`simulate` returns (spec sections 12, 19)."""
    return {name: pa.schema(fields) for name, fields in
            zip(TABLES, (_SUMMARY, _TIMESERIES, _TRIPS, _SNAPSHOTS))}


def simulate(params: LunarParams) -> dict[str, pa.Table]:
    """Every run of ``params`` (first_run .. first_run + runs - 1): ``{table: pyarrow.Table}``."""
    raise NotImplementedError("the lunar kernel is not written yet")
