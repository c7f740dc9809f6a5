"""Golden fingerprints: SHA-256 of the data of every table of a few short runs.

``python -m dronefleet.fingerprint`` prints them as the dict that ``tests/test_fingerprints.py``
pins; regenerate it with this command after an intentional change of the model's numbers.

The runs (:data:`RUNS`): one simulated week of the paper's 25 UAVs under every winner rule,
and a warm start (a second week from the fleet the ``least_confident`` week left behind).

Canonical serialisation of a table (:func:`table_digest`), schema metadata ignored: for each
column in order, the line ``name<TAB>type`` (Arrow's type string), then one line per row with
``repr`` of its Python value (``to_pylist``: exact for floats, whose ``repr`` round-trips;
``None`` for null; lists as Python lists), all UTF-8, each line ending in ``\\n``.
"""

from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from .delivery.config import Config, default_config, replace

if TYPE_CHECKING:
    import pyarrow

#: Name -> config changes of the fingerprinted runs (seed 0, 25 UAVs, one week, tau 15 min).
RUNS = {
    "least_confident": dict(rule="least_confident"),
    "most_confident": dict(rule="most_confident"),
    "random": dict(rule="random"),
    "threshold": dict(rule="threshold"),
    "reservation": dict(rule="reservation"),
}
#: The warm start: this run's fleet at its end starts a second week under the same rule.
WARM_FROM = "least_confident"


def table_digest(table: pyarrow.Table) -> str:
    """SHA-256 (hex) of a pyarrow table's column names, types and values, metadata aside."""
    digest = hashlib.sha256()
    for name, column in zip(table.column_names, table.columns):
        digest.update(f"{name}\t{column.type}\n".encode())
        for value in column.to_pylist():
            digest.update(f"{value!r}\n".encode())
    return digest.hexdigest()


def run_config(name: str) -> Config:
    """The config of fingerprinted run ``name`` (a key of :data:`RUNS`)."""
    return replace(default_config(), horizon_weeks=1.0, **RUNS[name])


def fingerprints() -> dict[str, dict[str, str]]:
    """{run name: {table name: SHA-256}} of every run of :data:`RUNS` and of ``"warm_start"``."""
    from .delivery.fleet import save_fleet
    from .delivery.records import tables
    from .delivery.simulation import simulate

    out = {}
    results = {}
    for name in RUNS:
        results[name] = simulate(run_config(name))
        out[name] = {table: table_digest(data) for table, data in tables(results[name]).items()}
    with tempfile.TemporaryDirectory() as tmp:
        path = save_fleet(results[WARM_FROM], Path(tmp) / "fleet.parquet")
        warm = simulate(replace(run_config(WARM_FROM), fleet_file=str(path)))
        out["warm_start"] = {table: table_digest(data) for table, data in tables(warm).items()}
    return out


def main() -> None:
    json.dump(fingerprints(), sys.stdout, indent=4, sort_keys=True)
    print()


if __name__ == "__main__":
    main()
