"""A verdict for every statement of docs/items-paper-checklist.md, option by option.

``dronefleet reproduce items-verdicts`` (:mod:`dronefleet.items.study`) reads the committed
tables of the items figures (the ``runs`` of Figs 3, 5, 7, 9, 12 and the t-tests), runs the
extra cells the options and the new measures need (:data:`EXTRA`: CAS seeing the others'
targets, the coarser item-delivery grid, ASTC's shared targets, SF's sleep-time changes,
Theorem 1's growing number of locations; about 40 s of one core) into ``extra.parquet``, and
applies each statement's test (:data:`STATEMENTS`) under each option it is tried with.

The rules are the checklist's: two algorithms are compared on per-trial values paired by
(cell, trial) (common random numbers), and a comparison agrees only where the mean paired
difference exceeds twice its standard error; "roughly the same" is within 10 % of the two
means' average. Each statement function returns one :class:`Result` per option tried, the
defaults first; :func:`verdict_of` turns them into holds / under option X only / does not hold /
not measured.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
import pandas as pd

from ..config import read_toml
from ..pairs import paired
from . import experiments
from .params import Params, grid_side

__all__ = ["HOLDS", "UNDER", "FAILS", "NOT_MEASURED", "VERDICTS", "STATEMENTS", "EXTRA", "Result", "Data",
           "extra_configs", "extra_rows", "verdict_of", "verdict_table", "paired"]

HOLDS, UNDER, FAILS, NOT_MEASURED = "holds", "under an option only", "does not hold", "not measured"
VERDICTS = (HOLDS, UNDER, FAILS, NOT_MEASURED)
DEFAULTS = "defaults"
#: "Roughly the same": within this share of the two means' average.
SIMILAR = 0.10
#: "A large margin" [percentage points].
LARGE = 5.0
#: The capacity panels of Figs 4, 6, 8 and 10; the speed panels of Fig 11.
PANELS = (5, 10, 15, 20)
SPEEDS = (0.2, 0.4, 0.6, 0.8)
#: The columns that identify a cell, with the trial: rows with equal values pair up.
PAIR_KEYS = ["n_robots", "capacity", "speed", "sigma_e", "mu_l", "trial"]
#: The committed figure tables the statements read.
FIGURE_TABLES = {"e1": "items-fig03", "e2": "items-fig05", "e3": "items-fig07", "e4": "items-fig09",
                 "e5": "items-fig12"}
#: The columns of ``extra.parquet`` besides the measures: the configuration and the trial's counts.
EXTRA_CONFIG = ("mode", "truth", "algorithm", "cas_variant", "lam_hat_source", "cas_targets", "locations",
                "n_robots", "capacity", "speed", "sigma_e", "mu_l", "sigma_l", "grid_spacing", "steps")
MEASURE_COLUMNS = ("trial", "generated", "served", "rate", "trips", "departures", "shared_targets",
                   "sf_updates_early", "sf_change_early", "sf_updates_late", "sf_change_late")
#: The option keys the committed tables vary, at their defaults.
OPTION_DEFAULTS = {"cas_variant": Params().cas_variant, "lam_hat_source": Params().lam_hat_source}
_TEAM = list(range(1, 11))
_CAPACITIES = list(range(1, 21))
#: The extra cells: name -> (the sweep file whose ``[set]`` they start from, or None, changes,
#: grid {key: values}). Each is the study's 20 trials of 1000 steps unless --quick.
EXTRA: dict[str, tuple[str | None, dict, dict]] = {
    "e1-shared": ("e1", {"algorithm": "CAS", "cas_targets": "shared"}, {"n_robots": _TEAM, "capacity": _CAPACITIES}),
    "e2-shared": ("e2", {"algorithm": "CAS", "cas_targets": "shared"}, {"n_robots": _TEAM, "capacity": _CAPACITIES}),
    "e1-targets": ("e1", {}, {"algorithm": ["R", "CAS"], "n_robots": _TEAM, "capacity": list(PANELS)}),
    "e3-measures": ("e3", {"sigma_e": 0.12}, {"algorithm": ["ASTC", "SF"], "n_robots": _TEAM,
                                              "capacity": list(PANELS)}),
    "e4a-shared": ("e4a", {"algorithm": "CAS", "cas_targets": "shared"}, {"n_robots": _TEAM,
                                                                         "capacity": list(PANELS)}),
    "e4a-coarse": ("e4a", {"grid_spacing": 0.1}, {"algorithm": ["GRIC", "GR", "R", "CAS"], "n_robots": _TEAM,
                                                  "capacity": list(PANELS)}),
    "e4a-trips": ("e4a", {"n_robots": 5, "capacity": 10}, {"algorithm": ["R", "GR"]}),
    "e5-shared": ("e5", {"algorithm": "CAS", "cas_targets": "shared"}, {"n_robots": [5, 10],
                                                                       "mu_l": [0.05, 0.10, 0.15]}),
    "e5-coarse": ("e5", {"grid_spacing": 0.1}, {"algorithm": ["GRIC", "GR", "R", "CAS"], "n_robots": [5, 10],
                                                "mu_l": [0.05, 0.10, 0.15]}),
    "theorem1": (None, {"truth": "bernoulli", "algorithm": "R", "n_robots": 5, "capacity": 10, "trials": 20,
                        "steps": 1000}, {"locations": [5, 20, 80, 320]}),
}
#: --quick: the study's (fewer trials and steps, n in (1, 5)).
QUICK_CHANGES = {"trials": 2, "steps": 200}
QUICK_TEAM = (1, 5)


@dataclasses.dataclass(frozen=True)
class Result:
    """One statement under one option: ``passes`` True/False (None: not measured), ``numbers`` in words."""

    option: str
    passes: bool | None
    numbers: str


# ---------------------------------------------------------------- the extra cells


def extra_configs(quick: bool = False) -> list[tuple[str, Params]]:
    """(extra set, configuration) of every cell of :data:`EXTRA` (--quick: fewer trials and steps, n in 1, 5)."""
    out = []
    for name, (sweep, changes, grid) in EXTRA.items():
        base = {}
        if sweep is not None:
            _, document = read_toml(experiments.grid_path(sweep), "sweep file")
            base = dict(document.get("set", {}))
        base.update(changes)
        if quick:
            base.update(QUICK_CHANGES)
            grid = {k: [v for v in values if k != "n_robots" or v in QUICK_TEAM] for k, values in grid.items()}
        for values in itertools.product(*grid.values()):
            out.append((name, Params(**base, **dict(zip(grid, values))).validate()))
    return out


def _measures_of(config: Params) -> dict:
    """Per-trial measures of one configuration (module level: it runs in worker processes)."""
    from .simulate import measures

    return measures(config)


def extra_rows(configs: Iterable[tuple[str, Params]], outcomes: Callable | None = None) -> pd.DataFrame:
    """Run ``configs`` (``outcomes(function, items)`` as :func:`experiments.run_configs` takes it;
    None: here) into one table: ``experiment`` (the extra set), :data:`EXTRA_CONFIG`, :data:`MEASURE_COLUMNS`
    (``rate``: % of generated, or F for logistic foraging, as the figures' tables)."""
    configs = list(configs)
    each = outcomes or (lambda function, items: ((item, function(item), None) for item in items))
    done = {}
    for config, result, error in each(_measures_of, list(dict.fromkeys(c for _, c in configs))):
        if error is not None:
            raise error
        done[config] = result
    frames = []
    for name, config in configs:
        m = done[config]
        trials = len(m["trial"])
        with np.errstate(divide="ignore", invalid="ignore"):
            rate = (m["served"].astype(np.float64) if config.truth == "logistic"
                    else np.where(m["generated"] > 0, 100.0 * m["served"] / np.maximum(m["generated"], 1), np.nan))
        head = {"experiment": name, **{c: getattr(config, c) for c in EXTRA_CONFIG}}
        frames.append(pd.DataFrame({**{k: np.repeat(v, trials) for k, v in head.items()},
                                    **{c: rate if c == "rate" else m[c] for c in MEASURE_COLUMNS}}))
    return pd.concat(frames, ignore_index=True)


# ---------------------------------------------------------------- the data and the rules


class Data:
    """The committed tables (``runs`` by experiment e1, e2, e3, e4 (E4a and E4b), e5; ``ttests``)
    and the extra cells, with the per-trial values each statement pairs."""

    def __init__(self, runs: dict[str, pd.DataFrame], ttests: pd.DataFrame, extra: pd.DataFrame):
        self.runs, self.ttests, self.extra = runs, ttests, extra
        self._rows: dict[tuple, pd.DataFrame] = {}

    def values(self, source: str, algorithm: str, option: dict | None = None, column: str = "rate",
               **where: Any) -> pd.Series:
        """``column`` of ``algorithm``'s trials, indexed by :data:`PAIR_KEYS`. ``source``: an
        experiment of the committed tables (e1, e2, e3, e4a, e4b, e5) or an extra set; ``option``:
        the option keys over their defaults (:data:`OPTION_DEFAULTS`; only those ``algorithm``
        reads filter); ``where``: {column: value or values}."""
        reads = {"CAS": ("cas_variant", "lam_hat_source"), "GR": ("lam_hat_source",),
                 "GRIC": ("lam_hat_source",)}.get(algorithm, ())
        chosen = tuple((k, v) for k, v in {**OPTION_DEFAULTS, **(option or {})}.items() if k in reads)
        key = (source, algorithm, chosen)
        if key not in self._rows:        # filtering the text columns is the slow part: once each
            if source in EXTRA:
                table = self.extra[self.extra["experiment"] == source]
            else:
                table = self.runs[source[:2]]
                table = table[table["experiment"] == source]
            mask = (table["algorithm"] == algorithm).to_numpy().copy()
            for name, value in chosen:
                if name in table:
                    mask &= (table[name] == value).to_numpy()
            self._rows[key] = table[mask]
        table = self._rows[key]
        mask = np.ones(len(table), dtype=bool)
        for name, value in where.items():
            values = value if isinstance(value, (list, tuple)) else [value]
            mask &= table[name].isin(values).to_numpy()
        return table[mask].set_index(PAIR_KEYS)[column].astype(float)


def _beyond(mean: float, se: float) -> bool:
    """Positive beyond twice its standard error."""
    return math.isfinite(mean) and mean > 2.0 * se


def _fmt(mean: float, se: float) -> str:
    return f"{mean:+.2f} (se {se:.2f})"


def _cells_below(a: pd.Series, b: pd.Series, keys: list[str]) -> tuple[int, int]:
    """(cells where ``a - b`` is negative beyond twice its standard error over the trials, cells)."""
    d = (a - b).dropna()
    if d.empty:
        return 0, 0
    stats = d.groupby(level=keys).agg(["mean", "std", "count"])
    se = stats["std"] / np.sqrt(stats["count"])
    return int((stats["mean"] < -2.0 * se).sum()), len(stats)


def _similar(a: float, b: float) -> bool:
    return abs(a - b) <= SIMILAR * abs(a + b) / 2.0


def _label(option: dict) -> str:
    return ", ".join(f"{k}={v!r}" if isinstance(v, str) else f"{k}={v:g}" for k, v in option.items()) or DEFAULTS


# The options the item-delivery statements are tried under (A2 x A9), the defaults first.
_A2 = ({}, {"cas_variant": "rate"})
_A2A9 = ({}, {"cas_variant": "rate"}, {"lam_hat_source": "mu"}, {"cas_variant": "rate", "lam_hat_source": "mu"})
_CELL = ["n_robots", "capacity", "speed", "sigma_e", "mu_l"]


def _ttest(data: Data, experiment: str, a: str, b: str, option: str) -> tuple[bool, str]:
    """The committed paired t-tests of ``a`` against ``b`` per capacity panel: all beyond 2 SE?"""
    t = data.ttests
    rows = t[(t["experiment"] == experiment) & (t["a"] == a) & (t["b"] == b) & (t["option"] == option)]
    rows = rows.sort_values("capacity")
    if rows.empty:
        return None, "no test"
    words = [f"c={int(r.capacity)}: {_fmt(r.mean_diff, abs(r.mean_diff / r.t_paired))}, p={r.p_paired:.1g}"
             for r in rows.itertuples()]
    return bool((rows["t_paired"] > 2.0).all() and (rows["mean_diff"] > 0).all()), "; ".join(words)


def _panels(data: Data, a: tuple, b: tuple, panel: str = "capacity", panels: Iterable = PANELS) -> tuple[bool, str]:
    """``a``, ``b`` = (source, algorithm, option): per panel, a - b paired by (n, trial); all beyond 2 SE?"""
    ok, words = True, []
    for value in panels:
        mean, se, _ = paired(data.values(*a, **{panel: value}), data.values(*b, **{panel: value}))
        ok &= _beyond(mean, se)
        words.append(f"{panel[0]}={value:g}: {_fmt(mean, se)}")
    return ok, "; ".join(words)


# ---------------------------------------------------------------- the statements


def i1(data: Data) -> list[Result]:
    """Foraging mapped to item delivery: identical trajectories and counts."""
    from .simulate import run_cell

    rng = np.random.default_rng(2015)
    positions = np.vstack([[0.5, 0.5], rng.uniform(0.0, 1.0, (20, 2))])
    rates = np.concatenate([[0.0], rng.uniform(0.05, 0.6, 20)])
    same, tried = True, []
    for algorithm in ("R", "GR", "CAS"):
        base = Params(algorithm=algorithm, n_robots=4, capacity=6, trials=5, steps=300)
        fp = run_cell(base.replace(count_at="pickup"), world=(positions, rates), trace=True)
        idp = run_cell(base.replace(mode="delivery", grid_spacing=0.25), world=(positions, rates), trace=True)
        same &= all(np.array_equal(fp[k], idp[k]) for k in ("totals", "trace", "trace_counts"))
        tried.append(algorithm)
    return [Result(DEFAULTS, same, f"{', '.join(tried)} on one world of 20 locations, 5 trials of 300 steps: "
                                   f"{'identical' if same else 'different'} trajectories and counts")]


def i2(data: Data) -> list[Result]:
    """Theorem 1: R's items per trip rise towards c with the number of locations."""
    runs = data.extra[data.extra["experiment"] == "theorem1"]
    if runs.empty:
        return [Result(DEFAULTS, None, "not run")]
    per = {m: (g.set_index("trial")["served"] / g.set_index("trial")["trips"]).astype(float)
           for m, g in runs.groupby("locations")}
    sizes = sorted(per)
    ok, words = True, [f"{m} locations: {per[m].mean():.2f}" for m in sizes]
    for small, large in zip(sizes, sizes[1:]):
        mean, se, _ = paired(per[large], per[small])
        ok &= _beyond(mean, se)
    capacity = int(runs["capacity"].iloc[0])
    ok &= per[sizes[-1]].mean() >= 0.95 * capacity
    return [Result(DEFAULTS, ok, f"items per trip (c = {capacity}): " + ", ".join(words))]


def _share(data: Data, source: str, algorithm: str, **where) -> pd.Series:
    shared = data.values(source, algorithm, None, "shared_targets", **where)
    return shared / data.values(source, algorithm, None, "departures", **where).replace(0, np.nan)


def i3(data: Data) -> list[Result]:
    """ASTC: two robots on one location is rare while n << |L|."""
    share = _share(data, "e3-measures", "ASTC")
    by_n = share.groupby(level="n_robots").mean()
    small = by_n[by_n.index <= 5]
    ok = bool(len(small)) and bool((small < 0.05).all())
    return [Result(DEFAULTS, ok, "share of departures to a location another robot targets: "
                   + ", ".join(f"n={n}: {100 * v:.1f} %" for n, v in by_n.items()))]


def i4(data: Data) -> list[Result]:
    """SF's sleep time keeps changing in the run's second half."""
    t = data.extra[(data.extra["experiment"] == "e3-measures") & (data.extra["algorithm"] == "SF")]
    early = t["sf_change_early"] / t["sf_updates_early"].replace(0, np.nan)
    late = t["sf_change_late"] / t["sf_updates_late"].replace(0, np.nan)
    mean, se, _ = paired(late, 0.0 * late)
    return [Result(DEFAULTS, _beyond(mean - 1.0, se),
                   f"mean |change| of the sleep time per update: {early.mean():.2f} steps in the first half, "
                   f"{mean:.2f} (se {se:.2f}) in the second ({int(t['sf_updates_late'].sum())} updates)")]


def _gr_against(experiment: str, other: str) -> Callable[[Data], list[Result]]:
    def statement(data: Data) -> list[Result]:
        out = []
        for option in ("max_expected", "rate") if other == "CAS" else ("max_expected",):
            ok, words = _ttest(data, experiment, "GR", other, option)
            out.append(Result(DEFAULTS if option == "max_expected" else _label({"cas_variant": option}), ok, words))
        if other == "CAS":
            ok, words = _panels(data, (experiment, "GR"), (f"{experiment}-shared", "CAS"))
            out.append(Result(_label({"cas_targets": "shared"}), ok, words))
        return out
    statement.__doc__ = f"{experiment}: GR beats {other} in every capacity panel."
    return statement


def i9(data: Data) -> list[Result]:
    """GR above CAS and R in every (n, c) cell of E1 and E2."""
    out = []
    for option in _A2:
        below, words = 0, []
        for experiment in ("e1", "e2"):
            gr = data.values(experiment, "GR")
            for other in ("CAS", "R"):
                n, cells = _cells_below(gr, data.values(experiment, other, option), _CELL)
                below += n
                words.append(f"{experiment} {other} above GR in {n} of {cells} cells")
        out.append(Result(_label(option), below == 0, "; ".join(words)))
    return out


def i10(data: Data) -> list[Result]:
    """n = 10, c = 20: every algorithm at 95 % or more."""
    out = []
    for option in _A2:
        means = {f"{e} {a}": data.values(e, a, option, n_robots=10, capacity=20).mean()
                 for e in ("e1", "e2") for a in ("R", "GR", "CAS")}
        out.append(Result(_label(option), all(v >= 95.0 for v in means.values()),
                          ", ".join(f"{k} {v:.1f} %" for k, v in means.items())))
    return out


def i11(data: Data) -> list[Result]:
    """R above CAS below c = 10, CAS above R above c = 10."""
    out = []
    for option in (*_A2, {"cas_targets": "shared"}):
        ok, words = True, []
        for experiment in ("e1", "e2"):
            source = f"{experiment}-shared" if "cas_targets" in option else experiment
            r_low, cas_low = (data.values(s, a, option, capacity=list(range(1, 10)))
                              for s, a in ((experiment, "R"), (source, "CAS")))
            r_high, cas_high = (data.values(s, a, option, capacity=list(range(11, 21)))
                                for s, a in ((experiment, "R"), (source, "CAS")))
            low, high = paired(r_low, cas_low), paired(cas_high, r_high)
            ok &= _beyond(*low[:2]) and _beyond(*high[:2])
            words.append(f"{experiment}: R - CAS at c < 10 {_fmt(*low[:2])}, CAS - R at c > 10 {_fmt(*high[:2])}")
        out.append(Result(_label(option), ok, "; ".join(words)))
    return out


def i12(data: Data) -> list[Result]:
    """CAS robots share destinations more than R's."""
    r = _share(data, "e1-targets", "R")
    out = []
    for option, cas in ((DEFAULTS, _share(data, "e1-targets", "CAS")),
                        (_label({"cas_targets": "shared"}), _share(data, "e1-shared", "CAS", capacity=list(PANELS)))):
        mean, se, _ = paired(cas, r)
        out.append(Result(option, _beyond(mean, se), f"share of departures to a location another robot targets: "
                                                     f"CAS {100 * cas.mean():.1f} %, R {100 * r.mean():.1f} %"))
    return out


def _astc_against(other: str) -> Callable[[Data], list[Result]]:
    def statement(data: Data) -> list[Result]:
        return [Result(DEFAULTS, *_ttest(data, "e3", "ASTC", other, "-"))]
    statement.__doc__ = f"E3 at sigma_e = 0.12: ASTC beats {other} in every capacity panel."
    return statement


def i15(data: Data) -> list[Result]:
    """ASTC above SF and R in every (n, c, sigma_e) cell of Fig 7."""
    astc, below, words = data.values("e3", "ASTC"), 0, []
    for other in ("SF", "R"):
        n, cells = _cells_below(astc, data.values("e3", other), _CELL)
        below += n
        words.append(f"{other} above ASTC in {n} of {cells} cells")
    return [Result(DEFAULTS, below == 0, "; ".join(words))]


def _sigmas(data: Data) -> list[float]:
    return sorted(data.runs["e3"]["sigma_e"].unique())


def i16(data: Data) -> list[Result]:
    """AS above SF at every sigma_e."""
    ok, words = True, []
    for sigma in _sigmas(data):
        mean, se, _ = paired(data.values("e3", "AS", sigma_e=sigma), data.values("e3", "SF", sigma_e=sigma))
        ok &= _beyond(mean, se)
        words.append(f"sigma_e={sigma:g}: AS - SF {_fmt(mean, se)}")
    return [Result(DEFAULTS, ok, "; ".join(words))]


def i17(data: Data) -> list[Result]:
    """R above AS with few robots, at some sigma_e."""
    ok, words = False, []
    for sigma in _sigmas(data):
        few = {"sigma_e": sigma, "n_robots": [1, 2, 3]}
        mean, se, _ = paired(data.values("e3", "R", **few), data.values("e3", "AS", **few))
        ok |= _beyond(mean, se)
        words.append(f"sigma_e={sigma:g}: R - AS at n <= 3 {_fmt(mean, se)}")
    return [Result(DEFAULTS, ok, "; ".join(words))]


def _noise_drops(data: Data) -> dict[str, tuple[float, float, float]]:
    """Per algorithm of E3: (mean F(0.08) - F(0.20), its se, that mean relative to F(0.08))."""
    low, high = min(_sigmas(data)), max(_sigmas(data))
    out = {}
    for algorithm in ("ASTC", "R", "AS", "SF"):
        a = data.values("e3", algorithm, sigma_e=low).droplevel("sigma_e")
        b = data.values("e3", algorithm, sigma_e=high).droplevel("sigma_e")
        mean, se, _ = paired(a, b)
        out[algorithm] = (mean, se, mean / float(a.mean()))
    return out


def i18(data: Data) -> list[Result]:
    """ASTC hardly affected by sigma_e (a drop within 2 SE, or under half the others' drops)."""
    drops = _noise_drops(data)
    mean, se, share = drops["ASTC"]
    others = min(d[2] for a, d in drops.items() if a != "ASTC")
    ok = not _beyond(abs(mean), se) or share < 0.5 * others
    return [Result(DEFAULTS, ok, "F at sigma_e 0.08 minus 0.20: " + "; ".join(
        f"{a} {_fmt(m, s)} ({100 * r:.1f} %)" for a, (m, s, r) in drops.items()))]


def i19(data: Data) -> list[Result]:
    """R, AS and SF do worse as sigma_e rises."""
    drops = _noise_drops(data)
    ok = all(_beyond(drops[a][0], drops[a][1]) for a in ("R", "AS", "SF"))
    return [Result(DEFAULTS, ok, "; ".join(f"{a}: {_fmt(drops[a][0], drops[a][1])} ({100 * drops[a][2]:.1f} %)"
                                           for a in ("R", "AS", "SF")))]


def i20(data: Data) -> list[Result]:
    """N_s in {N/20, N/10}: 400-1000 locations?"""
    out = []
    for edge in ("inclusive", "exclusive"):
        counts = {s: grid_side(s, edge) ** 2 for s in (0.05, 0.1)}
        out.append(Result(DEFAULTS if edge == "inclusive" else _label({"grid_edge": edge}),
                          all(400 <= c <= 1000 for c in counts.values()),
                          ", ".join(f"N_s = {s:g}: {c} locations" for s, c in counts.items())))
    return out


def _delivery_options() -> list[tuple[str, dict, str]]:
    """(label, option, E4a source) of the item-delivery options: A2 x A9 on the committed tables,
    then the coarser grid (its extra cells: the capacity panels only)."""
    return [*((_label(o), o, "e4a") for o in _A2A9), (_label({"grid_spacing": 0.1}), {}, "e4a-coarse")]


def i21(data: Data) -> list[Result]:
    """GRIC first in every cell of Fig 9a and 9b."""
    out = []
    for label, option, source in _delivery_options():
        below, words = 0, []
        for experiment in (source, "e4b") if source == "e4a" else (source,):
            gric = data.values(experiment, "GRIC", option)
            for other in ("GR", "R", "CAS"):
                n, cells = _cells_below(gric, data.values(experiment, other, option), _CELL)
                below += n
                words.append(f"{experiment} {other} above GRIC in {n} of {cells} cells")
        out.append(Result(label, below == 0, "; ".join(words)))
    return out


def i22(data: Data) -> list[Result]:
    """GRIC above GR, R and CAS in every slice panel (Figs 10, 11)."""
    out = []
    for label, option, source in _delivery_options():
        ok, words = True, []
        for other in ("GR", "R", "CAS"):
            good, text = _panels(data, (source, "GRIC", option), (source, other, option))
            ok &= good
            words.append(f"GRIC - {other} {text}")
            if source == "e4a":
                good, text = _panels(data, ("e4b", "GRIC", option), ("e4b", other, option), "speed", SPEEDS)
                ok &= good
                words.append(f"GRIC - {other} {text}")
        out.append(Result(label, ok, "; ".join(words)))
    return out


def _r_by_margin(other: str) -> Callable[[Data], list[Result]]:
    def statement(data: Data) -> list[Result]:
        options = _delivery_options() if other == "CAS" else [
            o for o in _delivery_options() if "cas_variant" not in o[1]]
        if other == "CAS":
            options.append((_label({"cas_targets": "shared"}), {}, "e4a-shared"))
        out = []
        for label, option, source in options:
            r_source = "e4a" if source == "e4a-shared" else source
            mine = data.values(source, other, option)
            r = data.values(r_source, "R").reindex(mine.index)
            mean, se, _ = paired(r, mine)
            out.append(Result(label, _beyond(mean, se) and mean >= LARGE,
                              f"R {r.mean():.1f} %, {other} {mine.mean():.1f} %: R - {other} {_fmt(mean, se)}"
                              + (" (capacity panels)" if source != "e4a" else "")))
        return out
    statement.__doc__ = f"R above {other} by a large margin in item delivery."
    return statement


def i25(data: Data) -> list[Result]:
    """R fills up more per trip than GR."""
    per = {a: data.values("e4a-trips", a, None, "served") / data.values("e4a-trips", a, None, "trips")
           for a in ("R", "GR")}
    mean, se, _ = paired(per["R"], per["GR"])
    return [Result(DEFAULTS, _beyond(mean, se), f"items per trip home (c = 10): R {per['R'].mean():.2f}, "
                                                f"GR {per['GR'].mean():.2f}, R - GR {_fmt(mean, se)}")]


def _fig12_options() -> list[tuple[str, dict, str, int]]:
    """(label, option, E5 source, n) of the Fig 12 options."""
    out = [(_label({**o, **({"n_robots": n} if n != 5 else {})}), o, "e5", n) for n in (5, 10) for o in _A2A9]
    out += [(_label({"grid_spacing": 0.1, **({"n_robots": n} if n != 5 else {})}), {}, "e5-coarse", n)
            for n in (5, 10)]
    out += [(_label({"cas_targets": "shared", **({"n_robots": n} if n != 5 else {})}), {}, "e5-shared", n)
            for n in (5, 10)]
    return out


def _fig12_means(data: Data, source: str, algorithm: str, option: dict, n: int) -> tuple[pd.Series, pd.Series]:
    """The share served at mu_l = 0.05 and at 0.15, by cell and trial (mu_l dropped: they pair)."""
    low = data.values(source, algorithm, option, n_robots=n, mu_l=0.05).droplevel("mu_l")
    high = data.values(source, algorithm, option, n_robots=n, mu_l=0.15).droplevel("mu_l")
    return low, high


def i26(data: Data) -> list[Result]:
    """GR and CAS serve roughly the same share as mu_l rises."""
    out = []
    for label, option, source, n in _fig12_options():
        ok, words = True, []
        for algorithm in ("GR", "CAS"):
            mine = "e5" if source == "e5-shared" and algorithm == "GR" else source
            low, high = (float(v.mean()) for v in _fig12_means(data, mine, algorithm, option, n))
            ok &= _similar(low, high)
            words.append(f"{algorithm} {low:.1f} -> {high:.1f} %")
        out.append(Result(label, ok, ", ".join(words)))
    return out


def i27(data: Data) -> list[Result]:
    """GRIC's and R's share falls as mu_l rises."""
    out = []
    for label, option, source, n in _fig12_options():
        if source == "e5-shared" or "cas_variant" in option:
            continue                     # neither GRIC nor R reads these
        ok, words = True, []
        for algorithm in ("GRIC", "R"):
            low, high = _fig12_means(data, source, algorithm, option, n)
            mean, se, _ = paired(low, high)
            ok &= _beyond(mean, se)
            words.append(f"{algorithm} {low.mean():.1f} -> {high.mean():.1f} % (drop {_fmt(mean, se)})")
        out.append(Result(label, ok, ", ".join(words)))
    return out


def i28(data: Data) -> list[Result]:
    """The team's utilisation: not recorded."""
    return [Result(DEFAULTS, None, "no table records how much of the time the robots are busy")]


def i29(data: Data) -> list[Result]:
    """The paper's algorithms above the benchmarks, pooled over every cell."""
    out = []
    for option in ({}, {"cas_variant": "rate"}, {"lam_hat_source": "mu"}, {"cas_targets": "shared"}):
        shared = "cas_targets" in option
        pairs = [(e, "GR", f"{e}-shared" if shared else e, "CAS") for e in ("e1", "e2")]
        if not shared:
            pairs += [("e3", "AS", "e3", "SF"), ("e3", "ASTC", "e3", "SF")]
        pairs += [("e4a", "GRIC", "e4a-shared" if shared else "e4a", "CAS"),
                  ("e4a", "GR", "e4a-shared" if shared else "e4a", "CAS")]
        ok, words = True, []
        for sa, a, sb, b in pairs:
            # foraging runs have one lam_hat_source (the robots' rates are the text's there)
            mine = option if sa.startswith("e4") else {k: v for k, v in option.items() if k != "lam_hat_source"}
            mean, se, _ = paired(data.values(sa, a, mine), data.values(sb, b, mine))
            ok &= _beyond(mean, se)
            words.append(f"{sa[:3]} {a} - {b} {_fmt(mean, se)}")
        out.append(Result(_label(option), ok, "; ".join(words)))
    return out


#: Each statement of the checklist and its test.
STATEMENTS: dict[str, Callable[[Data], list[Result]]] = {
    "I1": i1, "I2": i2, "I3": i3, "I4": i4,
    "I5": _gr_against("e1", "CAS"), "I6": _gr_against("e1", "R"),
    "I7": _gr_against("e2", "CAS"), "I8": _gr_against("e2", "R"),
    "I9": i9, "I10": i10, "I11": i11, "I12": i12, "I13": _astc_against("SF"), "I14": _astc_against("R"),
    "I15": i15, "I16": i16, "I17": i17, "I18": i18, "I19": i19, "I20": i20, "I21": i21, "I22": i22,
    "I23": _r_by_margin("CAS"), "I24": _r_by_margin("GR"), "I25": i25, "I26": i26, "I27": i27, "I28": i28,
    "I29": i29,
}


def verdict_of(results: list[Result]) -> tuple[str, str]:
    """(verdict, the options it holds under: "-" at the defaults or when it holds under none)."""
    if all(r.passes is None for r in results):
        return NOT_MEASURED, "-"
    if results[0].passes:
        return HOLDS, "-"
    passing = [r.option for r in results[1:] if r.passes]
    return (UNDER, "; ".join(passing)) if passing else (FAILS, "-")


def verdict_table(data: Data) -> pd.DataFrame:
    """One row per (statement, option tried): statement, verdict (the statement's), holds_under,
    option, passes ("yes", "no", "-" not measured), numbers."""
    rows = []
    for statement, test in STATEMENTS.items():
        results = test(data)
        verdict, under = verdict_of(results)
        for r in results:
            rows.append({"statement": statement, "verdict": verdict, "holds_under": under, "option": r.option,
                         "passes": "-" if r.passes is None else ("yes" if r.passes else "no"),
                         "numbers": r.numbers})
    return pd.DataFrame(rows, columns=["statement", "verdict", "holds_under", "option", "passes", "numbers"])
