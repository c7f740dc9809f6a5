"""A toy dronefleet scenario, packaged from outside: robots on a random walk that drains their battery.

Each of ``n_robots`` robots starts at home (the origin) with a full battery that lasts
``battery`` steps. Each step, every robot with charge left moves one unit north, east,
south or west at random and uses one step of charge; a robot that is home again recharges
fully; one whose battery is empty stays where it is, stranded. Pure numpy, deterministic
from the seed. The module is the scenario: it has every member of dronefleet's contract
(``dronefleet.contract.ScenarioContract``, docs/scenario-contract.md), and pyproject.toml
registers it as the entry point ``random_walk`` of the group ``dronefleet.scenarios``.
"""

import json
import tomllib
from dataclasses import asdict, dataclass

import numpy as np
import pyarrow as pa

from dronefleet.config import ConfigError, read_toml
from dronefleet.contract import Field
from dronefleet.records import read_config as read_table_config

NAME = "random_walk"
SCHEMA = {
    "seed": Field("run", "-", "[0, 2**63)", "seed of the walks"),
    "n_robots": Field("run", "robots", "[1, 100]", "robots walking"),
    "steps": Field("run", "steps", "[1, 10000]", "length of the run"),
    "battery": Field("run", "steps", "[1, 10000]", "steps a full battery lasts"),
}
DEFAULTS = {"seed": 0, "n_robots": 4, "steps": 100, "battery": 30}
_RANGES = {"seed": (0, 2**63 - 1), "n_robots": (1, 100), "steps": (1, 10_000), "battery": (1, 10_000)}
TABLES = ("robots", "summary")
FIGURES = ()
SEED_KEY, SEEDS_REQUIRED = "seed", True
MOVES = np.array([[0, 1], [1, 0], [0, -1], [-1, 0]], dtype=np.int64)  # north, east, south, west


@dataclass(frozen=True)
class Config:
    seed: int
    n_robots: int
    steps: int
    battery: int

    def to_dict(self) -> dict:
        return {"scenario": NAME, "run": asdict(self)}

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)


def resolve_key(key):
    name = key.removeprefix("run.")
    if name not in SCHEMA:
        raise ConfigError(f"unknown key {key!r}; allowed keys: {', '.join(f'run.{k}' for k in SCHEMA)}")
    return name


def replace(config, changes):
    values = asdict(config)
    for key, value in changes.items():
        name = resolve_key(key)
        low, high = _RANGES[name]
        if not isinstance(value, int) or isinstance(value, bool) or not low <= value <= high:
            raise ConfigError(f"run.{name} = {value!r}: allowed an integer in {SCHEMA[name].allowed}", [name])
        values[name] = value
    return Config(**values)


def _from_document(document, where):
    """A config file's ``{scenario, run: {key: value}}`` -> Config."""
    run = document.get("run", {})
    if set(document) - {"scenario", "run"} or document.get("scenario", NAME) != NAME or not isinstance(run, dict):
        raise ConfigError(f"{where}: expected scenario = {NAME!r} and a section [run] of {', '.join(SCHEMA)}")
    return replace(Config(**DEFAULTS), run)


def load(path=None, overrides=(), seed=None):
    config = Config(**DEFAULTS) if path is None else _from_document(read_toml(path)[1], f"config file {str(path)!r}")
    changes = {}
    for text in overrides:
        key, equals, value = text.partition("=")
        try:
            changes[resolve_key(key.strip())] = tomllib.loads(f"value = {value}")["value"] if equals else None
        except tomllib.TOMLDecodeError:
            raise ConfigError(f"--set {text!r}: expected key=value, the value as in a config file") from None
    return replace(config, {**changes, **({} if seed is None else {"seed": seed})})


def value(config, name):
    return getattr(config, name)


def read_config(path):
    return read_table_config(path, lambda document: _from_document(document, f"table {str(path)!r}"))


def table_schemas():
    integers = [(name, pa.int64()) for name in ("robot", "x", "y", "charge", "moved")]
    return {"robots": pa.schema(integers),
            "summary": pa.schema([("seed", pa.int64()), ("moved_mean", pa.float64()),
                                  ("distance_mean", pa.float64()), ("stranded", pa.int64())])}


def simulate(config):
    rng = np.random.default_rng(config.seed)
    directions = rng.integers(0, len(MOVES), size=(config.steps, config.n_robots))
    position = np.zeros((config.n_robots, 2), dtype=np.int64)
    charge = np.full(config.n_robots, config.battery, dtype=np.int64)
    moved = np.zeros(config.n_robots, dtype=np.int64)
    for step in directions:
        walking = charge > 0
        position[walking] += MOVES[step[walking]]
        charge -= walking
        moved += walking
        charge[(position == 0).all(axis=1)] = config.battery  # home: recharged
    distance = np.sqrt((position * position).sum(axis=1).astype(np.float64))
    robots = pa.table({"robot": np.arange(config.n_robots, dtype=np.int64), "x": position[:, 0],
                       "y": position[:, 1], "charge": charge, "moved": moved})
    summary = pa.table({"seed": [config.seed], "moved_mean": [float(moved.mean())],
                        "distance_mean": [float(distance.mean())], "stranded": [int((charge == 0).sum())]},
                       schema=table_schemas()["summary"])
    return {"robots": robots, "summary": summary}


def format_summary(tables):
    row = tables["summary"].to_pylist()[0]
    return (f"  {'steps moved':<22}{row['moved_mean']:.1f} per robot\n"
            f"  {'distance from home':<22}{row['distance_mean']:.2f} (mean)\n"
            f"  {'stranded robots':<22}{row['stranded']}")


def describe(config):
    return f"seed {config.seed}, {config.n_robots} robots, {config.steps} steps, battery {config.battery} steps"


def label(config):
    return f"seed{config.seed}"
