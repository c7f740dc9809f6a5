"""Property-based tests of the loaders: any input gives a result or the project's own error.

Config files, ``--set`` overrides and nested dicts (``ConfigError``), fleet files
(``FleetFileError``, a ConfigError) and Nadzoru 2 supervisor files (``SupervisorFileError``,
a ConfigError): never another exception, and a message on one line. Deterministic
(``derandomize``) and small, so that CI is stable and fast.
"""

import math
import tempfile
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dronefleet.config import ConfigError
from dronefleet.delivery.config import (PARAMETERS, SECTIONS, Config, config_from_dict, default_config, load_config,
                                        replace)
from dronefleet.delivery.fleet import COLUMNS, SavedFleet, load_fleet
from dronefleet.records import write_table
from dronefleet.supervisor import BUILTIN_CONTROLLER, Automaton, SupervisorFileError, load_supervisor

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def outcome(load, *args, **kwargs):
    """``load(*args)``'s result, or the ConfigError it raised (after checking its message is one line)."""
    try:
        return load(*args, **kwargs)
    except ConfigError as error:  # SupervisorFileError and FleetFileError included
        assert "\n" not in str(error) and str(error)
        return error


# --------------------------------------------------------------------------- config

names = st.sampled_from(sorted(PARAMETERS)) | st.text(max_size=12)
sections = st.sampled_from(sorted(SECTIONS)) | st.text(max_size=8)
scalars = (st.integers() | st.integers(min_value=-2**70, max_value=2**70) | st.floats() | st.booleans()
           | st.text(max_size=20) | st.none())
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=5)
                      | st.dictionaries(st.text(max_size=5), inner, max_size=3), max_leaves=10)


@SETTINGS
@given(st.dictionaries(sections | st.integers(), st.dictionaries(names | st.integers(), values, max_size=5)
                       | values, max_size=4))
def test_any_nested_dict_gives_a_config_or_a_config_error(d):
    result = outcome(config_from_dict, d)
    assert isinstance(result, (Config, ConfigError))


def toml_literal(value):
    """A TOML spelling of a scalar (or a list of them); floats incl. nan/inf, ints of any size."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_literal(v) for v in value) + "]"
    return str(value)


toml_values = st.recursive(st.integers(min_value=-10**30, max_value=10**30) | st.floats() | st.booleans()
                           | st.text(alphabet=st.characters(codec="utf-8", exclude_categories=["Cs", "Cc"]),
                                     max_size=10),
                           lambda inner: st.lists(inner, max_size=4), max_leaves=8)
toml_lines = st.one_of(
    st.builds(lambda s: f"[{s}]", sections),
    st.builds(lambda k, v: f"{k} = {toml_literal(v)}", names, toml_values),
    st.text(max_size=30),
)


@SETTINGS
@given(st.lists(toml_lines, max_size=8), st.binary(max_size=40))
def test_any_config_file_gives_a_config_or_a_config_error(lines, junk):
    with tempfile.TemporaryDirectory() as folder:
        for data in ("\n".join(lines).encode("utf-8", "surrogatepass"), junk):
            path = Path(folder) / "run.toml"
            path.write_bytes(data)
            assert isinstance(outcome(load_config, path), (Config, ConfigError))


overrides = st.one_of(
    st.builds(lambda k, v: f"{k}={v}", names | st.builds(lambda s, k: f"{s}.{k}", sections, names),
              st.builds(toml_literal, toml_values) | st.text(max_size=20)),
    st.text(max_size=30),
)


@SETTINGS
@given(st.lists(overrides, max_size=5), st.none() | st.integers())
def test_any_overrides_and_seed_give_a_config_or_a_config_error(texts, seed):
    assert isinstance(outcome(load_config, None, texts, seed), (Config, ConfigError))


# --------------------------------------------------------------------------- fleet files

FLOAT_COLUMNS = ("t_s", "soh", "w_distance", "w_mass", "w_soc", "intercept", "steps", "soc")
ARROW_TYPES = {"float": pa.float64(), "int16": pa.int16(), "int64": pa.int64(), "bool": pa.bool_(),
               "string": pa.string()}
cells = {
    "float": st.none() | st.floats() | st.sampled_from([0.0, 0.5, 1.0, 15.0, 80.0, 100.0]),
    "int16": st.none() | st.integers(-2**15, 2**15 - 1) | st.sampled_from([0, 1, 2]),
    "int64": st.none() | st.integers(-2**63, 2**63 - 1) | st.sampled_from([0, 1, 2]),
    "bool": st.none() | st.booleans(),
    "string": st.none() | st.text(max_size=5),
}


@st.composite
def fleet_tables(draw):
    """A valid fleet of 1..4 UAVs (drawn values), then up to 3 hostile changes: a cell, a column's type, a drop."""
    n = draw(st.integers(1, 4))
    unit = st.floats(0.01, 1.0)
    columns = {
        "t_s": [draw(st.sampled_from([0.0, 604800.0]))] * n, "uav": list(range(n)),
        "soh": draw(st.lists(unit, min_size=n, max_size=n)),
        **{name: draw(st.lists(st.floats(-50, 50), min_size=n, max_size=n))
           for name in ("w_distance", "w_mass", "w_soc", "intercept")},
        "steps": [float(k) for k in draw(st.lists(st.integers(0, 10**6), min_size=n, max_size=n))],
        "soc": draw(st.lists(st.floats(0, 100), min_size=n, max_size=n)),
        "lost": draw(st.lists(st.booleans(), min_size=n, max_size=n)), "period": [draw(st.integers(1, 5))] * n,
    }
    kinds = {name: "float" if name in FLOAT_COLUMNS else "bool" if name == "lost" else "int16" for name in COLUMNS}
    for _ in range(draw(st.integers(0, 3))):
        name = draw(st.sampled_from(COLUMNS))
        if name not in columns:
            continue
        action = draw(st.sampled_from(["cell", "cell", "type", "drop", "rows"]))
        if action == "cell":
            columns[name][draw(st.integers(0, n - 1))] = draw(cells[kinds[name]])
        elif action == "type":
            kinds[name] = draw(st.sampled_from(sorted(ARROW_TYPES)))
            columns[name] = draw(st.lists(cells[kinds[name]], min_size=n, max_size=n))
        elif action == "drop":
            del columns[name]
        else:  # a row fewer everywhere: fewer UAVs than the config says
            columns = {key: values[:-1] for key, values in columns.items()}
            n -= 1
            if n == 0:
                break
    return pa.table({name: pa.array(values, type=ARROW_TYPES[kinds[name]]) for name, values in columns.items()})


@SETTINGS
@given(fleet_tables(), st.integers(0, 2), st.integers(0, 2), st.booleans())
def test_any_fleet_table_gives_a_fleet_or_a_fleet_file_error(table, saved_extra, run_extra, with_metadata):
    # The saved and the run's fleet sizes: mostly the table's, sometimes one more.
    saved_uavs = max(table.num_rows, 1) + (saved_extra == 2)
    run_uavs = max(table.num_rows, 1) + (run_extra == 2)
    run = replace(default_config(), n_uavs=run_uavs)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fleet.parquet"
        if with_metadata or saved_extra:
            write_table(table, path, replace(default_config(), n_uavs=saved_uavs))
        else:
            pq.write_table(table, path)
        result = outcome(load_fleet, path, run)
    assert isinstance(result, (SavedFleet, ConfigError))
    if isinstance(result, SavedFleet):  # what the engine may rely on
        assert result.soh.shape == (run_uavs,) and ((result.soh > 0) & (result.soh <= 1)).all()
        assert np.isfinite(result.coef).all() and np.isfinite(result.intercept).all()
        assert (result.steps >= 0).all() and (result.steps == np.floor(result.steps)).all()
        soc = result.soc[~result.lost]
        assert ((soc >= 0) & (soc <= 100)).all() and result.period >= 1


@SETTINGS
@given(st.binary(max_size=200))
def test_any_bytes_as_a_fleet_file_give_a_fleet_file_error(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fleet.parquet"
        path.write_bytes(data)
        assert isinstance(outcome(load_fleet, path, default_config()), ConfigError)


# --------------------------------------------------------------------------- supervisor files

yaml_text = st.text(alphabet=st.sampled_from(list("[]{}:,-&*!|>'\"#?% \n\t0123456789EV_abxyz.") + ["\u00e9"]),
                    max_size=120)


@SETTINGS
@given(yaml_text)
def test_any_yaml_text_gives_an_automaton_or_a_supervisor_file_error(text):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "controller.yaml"
        path.write_text(text, encoding="utf-8")
        result = outcome(load_supervisor, path)
    assert isinstance(result, (Automaton, SupervisorFileError))


PACKAGED = yaml.safe_load(BUILTIN_CONTROLLER.read_text())
leaf = st.integers(-3, 300) | st.integers() | st.sampled_from(PACKAGED["events"]) | st.text(max_size=6) \
    | st.booleans() | st.none() | st.floats()
nadzoru_values = st.recursive(leaf, lambda inner: st.lists(inner, max_size=6), max_leaves=30)


@st.composite
def nadzoru_documents(draw):
    """The packaged controller with a few keys dropped, replaced or mutated entry by entry."""
    doc = {key: (list(value) if isinstance(value, list) else value) for key, value in PACKAGED.items()}
    for _ in range(draw(st.sampled_from([0, 1, 1, 1, 2, 3]))):
        key = draw(st.sampled_from(sorted(doc)))
        action = draw(st.sampled_from(["drop", "replace", "mutate", "mutate", "mutate"]))
        if action == "drop":
            doc.pop(key, None)
        elif action == "replace" or not isinstance(doc.get(key), list) or not doc[key]:
            doc[key] = draw(nadzoru_values)
        else:
            i = draw(st.integers(0, len(doc[key]) - 1))
            doc[key][i] = draw(nadzoru_values)
    return doc


@SETTINGS
@given(nadzoru_documents())
def test_any_structured_document_gives_an_automaton_or_a_supervisor_file_error(doc):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "controller.yaml"
        path.write_text(yaml.safe_dump(doc), encoding="utf-8")
        result = outcome(load_supervisor, path)
    assert isinstance(result, (Automaton, SupervisorFileError))
    if isinstance(result, Automaton):
        assert isinstance(outcome(result.transition_table, result.events), (np.ndarray, SupervisorFileError))


def test_the_properties_see_both_outcomes():
    """The strategies reach valid inputs too (else 'never another exception' would say little)."""
    assert isinstance(load_config(overrides=["tau_minutes=20", "auction.rule=random"]), Config)
    assert isinstance(config_from_dict({"orders": {"tau_minutes": 20}}), Config)
    assert isinstance(load_supervisor(BUILTIN_CONTROLLER), Automaton)
    with pytest.raises(ConfigError):
        config_from_dict({"orders": {"tau_minutes": math.nan}})
