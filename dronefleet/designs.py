"""Sampled designs: the ``[design]`` section of a sweep file, an alternative to ``[grid]``.

A grid takes the full product of a few values per key; past three keys it grows beyond any
budget. A design instead samples points from ranges of many keys at once, as global
sensitivity analysis needs (Saltelli et al. 2008, *Global Sensitivity Analysis: The Primer*,
ch. 4)::

    [design]
    method = "sobol"          # sobol (Saltelli's scheme), morris, lhs, sobol-seq
    samples = 64              # base samples N
    sampling_seed = 0         # seed of the sampling (default 0); the runs' seeds are [sweep] seeds
    [design.ranges]           # key = [low, high]; a key of words or switches: its levels
    tau_minutes = [15.0, 40.0]
    n_uavs = [10, 40]         # an integer key: each integer of the range is as likely
    rule = ["least_confident", "random"]

The methods, and how many points ``samples = N`` gives for D keys:

========== ================================================ =====================
method     sampling                                         points
========== ================================================ =====================
sobol      Saltelli's cross-sampling of a scrambled Sobol'  N (2D + 2), or N (D + 2)
           sequence (SALib ``sample.sobol``), for first-,   with ``second_order =
           second- and total-order indices                  false``; N a power of 2
morris     N trajectories of Morris's one-at-a-time         N (D + 1)
           screening (SALib ``sample.morris``) on
           ``morris_levels`` levels (default 4)
lhs        Latin hypercube (``scipy.stats.qmc``)            N
sobol-seq  a scrambled Sobol' sequence (``scipy.stats.qmc``) N, a power of 2
========== ================================================ =====================

Every point is drawn in the unit cube and mapped to each key's range: a float key linearly
(the value rounded to 6 significant digits, so that partition folders stay readable), an
integer key to one of its integers with equal probability, a key of levels to one of them
with equal probability. Points that map to the same values (integer keys, levels) share one
run: a sweep runs each configuration once, and the analysis gives each point its run's
result. Each distinct point is a run like a grid cell, times the sweep's seeds. The points are
stored in the dataset (:data:`SAMPLES_FILE`), in sample order, with their unit coordinates.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .config import SweepError, _show

if TYPE_CHECKING:
    import numpy
    import pyarrow

    from .scenarios import Scenario

#: The sampling methods of a ``[design]``.
METHODS = ("sobol", "morris", "lhs", "sobol-seq")
#: The keys of ``[design]``.
DESIGN_KEYS = ("method", "samples", "sampling_seed", "ranges", "second_order", "morris_levels")
#: In a dataset folder, a design's points in sample order (``sample``, each key's value, its unit coordinate).
SAMPLES_FILE = "samples.parquet"
#: The metadata key of :data:`SAMPLES_FILE` that holds the design (JSON).
DESIGN_KEY = b"dronefleet.design"
#: Significant digits of a float key's sampled value.
DIGITS = 6
#: Methods whose base sample count must be a power of 2: a Sobol' sequence is balanced only then.
_POWERS_OF_TWO = ("sobol", "sobol-seq")


@dataclass(frozen=True)
class Factor:
    """One key of a design: a range ``[low, high]`` of a float or integer key, or ``levels``."""

    name: str
    low: float | int | None = None
    high: float | int | None = None
    levels: tuple | None = None      # the values of a key of words or switches, in the file's order
    integer: bool = False

    def values(self, unit: numpy.ndarray) -> list:
        """The config values of unit coordinates ``unit`` (shape (n,), each in [0, 1])."""
        import numpy as np

        if self.levels is not None:
            index = np.minimum((unit * len(self.levels)).astype(np.int64), len(self.levels) - 1)
            return [self.levels[k] for k in index]
        if self.integer:
            # floor over high - low + 1 equal cells: each integer equally likely, u = 1 is the top one
            offset = np.minimum((unit * (self.high - self.low + 1)).astype(np.int64), self.high - self.low)
            return [int(self.low + k) for k in offset]
        scaled = self.low + unit * (self.high - self.low)
        return [min(max(float(f"{x:.{DIGITS}g}"), self.low), self.high) for x in scaled]

    def to_dict(self) -> dict:
        return {"levels": list(self.levels)} if self.levels is not None else {"low": self.low, "high": self.high}


@dataclass(frozen=True)
class Design:
    """A ``[design]``, read, validated and sampled."""

    method: str
    samples: int                      # base samples N
    sampling_seed: int
    second_order: bool                # sobol: second-order indices too (N (2D + 2) points, not N (D + 2))
    morris_levels: int                # morris: the levels of each key on its grid of the unit cube
    factors: tuple[Factor, ...]       # sorted by name
    unit: numpy.ndarray = field(compare=False, repr=False)     # (points, D): the points in the unit cube
    points: tuple[tuple, ...] = field(compare=False, repr=False)  # each point's config values, by factor

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(factor.name for factor in self.factors)

    def distinct(self) -> list[dict[str, Any]]:
        """The distinct points as config changes (key -> value), in order of first appearance."""
        return [dict(zip(self.keys, point)) for point in dict.fromkeys(self.points)]

    def describe(self) -> str:
        """``sobol design: 64 samples of 4 keys = 640 points (631 distinct)``."""
        distinct = len(set(self.points))
        repeats = f" ({distinct} distinct)" if distinct != len(self.points) else ""
        return (f"{self.method} design: {self.samples} samples of {len(self.factors)} "
                f"key{'s' if len(self.factors) != 1 else ''} = {len(self.points)} points{repeats}")

    def to_dict(self) -> dict:
        """The design as the dataset records it (JSON)."""
        return {"method": self.method, "samples": self.samples, "sampling_seed": self.sampling_seed,
                "second_order": self.second_order, "morris_levels": self.morris_levels,
                "ranges": {factor.name: factor.to_dict() for factor in self.factors}}

    def problem(self) -> dict:
        """SALib's problem: every key over the unit interval (the analysis works on unit coordinates)."""
        return {"num_vars": len(self.factors), "names": list(self.keys), "bounds": [[0.0, 1.0]] * len(self.factors)}

    def table(self) -> pyarrow.Table:
        """The points in sample order: ``sample``, each key's value, then ``unit_<key>`` (its unit coordinate)."""
        import pyarrow as pa

        columns = {"sample": pa.array(range(len(self.points)), pa.int64())}
        for k, key in enumerate(self.keys):
            columns[key] = pa.array([point[k] for point in self.points])
        for k, key in enumerate(self.keys):
            columns[f"unit_{key}"] = pa.array(self.unit[:, k], pa.float64())
        return pa.table(columns).replace_schema_metadata({DESIGN_KEY: json.dumps(self.to_dict())})


def n_points(method: str, samples: int, n_keys: int, second_order: bool = True) -> int:
    """How many points ``samples`` base samples of ``n_keys`` keys give (see the module's table)."""
    if method == "sobol":
        return samples * (2 * n_keys + 2 if second_order else n_keys + 2)
    if method == "morris":
        return samples * (n_keys + 1)
    return samples


def _integer(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _factor(name: str, spec, default, where: str) -> Factor:
    """The factor of ``name = spec`` in ``[design.ranges]``, ``default`` its scenario's default value."""
    if isinstance(default, (str, bool)):
        kind = "a switch" if isinstance(default, bool) else "a word"
        if not isinstance(spec, list) or len(spec) < 2 or not all(type(v) is type(default) for v in spec):
            raise SweepError(f"{where}: {name} is {kind}: give its levels, a list of at least two such values, "
                             f"got {_show(spec)}", [name])
        if len(set(spec)) != len(spec):
            raise SweepError(f"{where}: {name} lists a level more than once: {_show(spec)}", [name])
        return Factor(name, levels=tuple(spec))
    if not isinstance(default, (int, float)):
        raise SweepError(f"{where}: {name} holds a list of numbers and cannot be a design key (a partition value "
                         "is one number or string); set it in [set] or the base", [name])
    integer = _integer(default)
    number = _integer if integer else (lambda v: isinstance(v, (int, float)) and not isinstance(v, bool))
    if not (isinstance(spec, list) and len(spec) == 2 and all(number(v) for v in spec)
            and all(math.isfinite(v) for v in spec)):
        kind = "integers" if integer else "numbers"
        raise SweepError(f"{where}: {name} must be a range [low, high] of two {kind}, got {_show(spec)}", [name])
    low, high = spec if integer else (float(spec[0]), float(spec[1]))
    if not low < high:
        raise SweepError(f"{where}: {name} = {_show(spec)}: low must be below high", [name])
    return Factor(name, low, high, integer=integer)


def read_design(table, ranges: dict[str, Any], scenario: Scenario, where: str, max_runs: int,
                n_seeds: int = 1) -> Design:
    """The design of a ``[design]`` table ``table``, whose ``ranges`` the caller has resolved to
    parameter names (``ranges``: name -> spec): validated, then sampled.

    ``max_runs``: the most runs a sweep may hold, each point running ``n_seeds`` times; checked
    before anything is sampled. SweepError (one line naming the key and what is allowed) on an
    unknown key or method, a count that is not allowed, a range whose low is not below its high,
    a key of the wrong kind, or too many points.
    """
    if not isinstance(table, dict):
        raise SweepError(f"{where} must be a table of key = value")
    for key in table:
        if key not in DESIGN_KEYS:
            raise SweepError(f"{where}: unknown key {key!r}. Allowed: {', '.join(DESIGN_KEYS)}")
    method = table.get("method")
    if method not in METHODS:
        raise SweepError(f"{where}: method = {_show(method)} is not a method. Allowed: {', '.join(METHODS)}")
    samples = table.get("samples")
    if not _integer(samples) or samples < 2:
        raise SweepError(f"{where}: samples must be an integer >= 2, got {_show(samples)}")
    if method in _POWERS_OF_TWO and samples & (samples - 1):
        below = 1 << (samples.bit_length() - 1)
        raise SweepError(f"{where}: samples = {samples}: a {method} design takes a power of 2 (a Sobol' sequence "
                         f"is balanced only then), e.g. {below} or {2 * below}")
    sampling_seed = table.get("sampling_seed", 0)
    if not _integer(sampling_seed) or not 0 <= sampling_seed < 2 ** 63:
        raise SweepError(f"{where}: sampling_seed must be an integer in 0..2**63-1, got {_show(sampling_seed)}")
    second_order = table.get("second_order", True)
    if not isinstance(second_order, bool) or ("second_order" in table and method != "sobol"):
        raise SweepError(f"{where}: second_order is true or false, for method = \"sobol\" only")
    morris_levels = table.get("morris_levels", 4)
    if not _integer(morris_levels) or morris_levels < 2 or ("morris_levels" in table and method != "morris"):
        raise SweepError(f"{where}: morris_levels is an integer >= 2, for method = \"morris\" only, "
                         f"got {_show(morris_levels)}")
    if not ranges:
        raise SweepError(f"{where}: ranges is empty or missing: give [design.ranges] with at least one "
                         "key = [low, high]")
    factors = tuple(_factor(name, spec, scenario.defaults[name], f"{where}.ranges")
                    for name, spec in sorted(ranges.items()))
    if method == "sobol" and len(factors) < 2:
        raise SweepError(f"{where}: a sobol design needs at least two keys in [design.ranges]")
    count = n_points(method, samples, len(factors), second_order)
    if count * n_seeds > max_runs:
        raise SweepError(f"{where}: {method} with samples = {samples} over {len(factors)} keys gives {count:,} "
                         f"points x {n_seeds} seed{'s' if n_seeds != 1 else ''} = {count * n_seeds:,} runs; a sweep "
                         f"may hold at most {max_runs:,} runs: take fewer samples or seeds")
    unit = _sample(method, samples, len(factors), sampling_seed, second_order, morris_levels)
    columns = [factor.values(unit[:, k]) for k, factor in enumerate(factors)]
    return Design(method, samples, sampling_seed, second_order, morris_levels, factors, unit, tuple(zip(*columns)))


def _sample(method: str, samples: int, n_keys: int, seed: int, second_order: bool,
            morris_levels: int) -> numpy.ndarray:
    """The points of a design in the unit cube, shape (points, n_keys), from the seeded sampler."""
    from scipy.stats import qmc

    problem = {"num_vars": n_keys, "names": [f"x{k}" for k in range(n_keys)], "bounds": [[0.0, 1.0]] * n_keys}
    if method == "sobol":
        from SALib.sample import sobol

        return sobol.sample(problem, samples, calc_second_order=second_order, seed=seed)
    if method == "morris":
        from SALib.sample import morris

        return morris.sample(problem, samples, num_levels=morris_levels, seed=seed)
    if method == "lhs":
        return qmc.LatinHypercube(d=n_keys, seed=seed).random(samples)
    return qmc.Sobol(d=n_keys, scramble=True, seed=seed).random(samples)


def write_samples(design: Design, out: Path) -> None:
    """Write the design's points into the dataset ``out`` (:data:`SAMPLES_FILE`, atomically)."""
    import pyarrow.parquet as pq

    from .records import write_atomic

    table = design.table()
    write_atomic(out / SAMPLES_FILE, lambda tmp: pq.write_table(table, tmp))
