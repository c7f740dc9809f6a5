"""Hostile values, from every door (config and sweep files, ``--set``, ``dronefleet.run`` and
``dronefleet.sweep``): each is refused in one line naming the key or argument (a ConfigError in
Python, exit 2 on the command line), and the checks themselves neither crash nor crawl: values
nested thousands deep (TOML's dotted keys ``a.a.a...``, Python lists), holding themselves, of
thousands of digits, or whose repeats must be found among 100,000 lists.
"""

import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import Counted

import dronefleet
from dronefleet import cli, sweeps as sw
from dronefleet.config import MAX_DEPTH, ConfigError, _show

REPLENISHMENT_TOML = Path(dronefleet.__file__).resolve().parent.parent / "configs" / "replenishment.toml"
DEEP_KEY = "a." * 5000 + "a"   # TOML builds the tables of dotted keys without recursion: any depth


def nested(depth, leaf=1):
    for _ in range(depth):
        leaf = [leaf]
    return leaf


def holding_itself():
    value = []
    value.append(value)
    return value


def refused(capsys, args, *fragments):
    """Exit 2 and ONE stderr line holding every fragment, no traceback."""
    try:
        code = cli.main(args)
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err
    assert code == 2, err[-2000:]
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err[-2000:]
    assert len(err) < 2000, err[:2000]   # a value is never printed whole
    assert all(fragment in err for fragment in fragments), err


@pytest.mark.parametrize("text, key", [
    (f'scenario = "replenishment"\n[run]\ntrials.{DEEP_KEY} = 1\n', "run.trials.a.a"),
    (f"[orders]\ntau_minutes.{DEEP_KEY} = 1\n", "orders.tau_minutes.a.a"),
    (f"[orders]\ntau_minutes = [{{{DEEP_KEY} = 1}}]\n", "orders.tau_minutes[0].a.a"),
])
def test_config_files_nested_deeply_by_dotted_keys_are_refused_naming_the_key(tmp_path, capsys, text, key):
    path = tmp_path / "deep.toml"
    path.write_text(text)
    out = tmp_path / "out"
    refused(capsys, ["run", str(path), "--out", str(out)], str(path), key, f"more than {MAX_DEPTH} deep")
    assert not out.exists()
    if "replenishment" in text:
        refused(capsys, ["bounds", str(path)], key)


@pytest.mark.parametrize("body, key", [
    (f"[grid]\nrun.trials.{DEEP_KEY} = 1\n", "grid.run.trials.a.a"),
    (f"[set]\nrun.trials.{DEEP_KEY} = 1\n[grid]\nticks = [10]\n", "set.run.trials.a.a"),
    (f"[grid]\nticks = [{{{DEEP_KEY} = 1}}, 2]\n", "grid.ticks[0].a.a"),
])
def test_sweep_files_nested_deeply_are_refused_naming_the_key(tmp_path, capsys, body, key):
    path = tmp_path / "deep.toml"
    path.write_text('[sweep]\nscenario = "replenishment"\n' + body)
    results = tmp_path / "results"
    refused(capsys, ["sweep", "plan", str(path), "--results", str(results)], key)
    assert not results.exists()


@pytest.mark.parametrize("value", [f"{{{DEEP_KEY} = 1}}", f"[{{{DEEP_KEY} = 1}}]"])
def test_set_values_nested_deeply_are_refused_naming_the_key(tmp_path, capsys, value):
    refused(capsys, ["run", "--set", f"tau_minutes={value}", "--out", str(tmp_path / "out")],
            "--set tau_minutes", f"more than {MAX_DEPTH} deep")
    assert not (tmp_path / "out").exists()


def test_a_value_is_shown_from_its_first_characters_however_deep_or_big():
    for value in (nested(5000), holding_itself()):
        assert _show(value).startswith("[[[[") and "..." in _show(value) and len(_show(value)) <= 60
    assert _show([10**5000]) == "[an integer of 16610 bits]"
    assert _show(10**5000) == "an integer of 16610 bits"
    assert _show(list(range(10**6))).startswith("[0, 1, 2") and "..." in _show(list(range(10**6)))
    assert len(_show(list(range(10**6)))) <= 60
    for value in ({"a": (1,), "b": set(), "c": frozenset({2})}, [], (), {}, "x", 1.5, None):
        assert _show(value) == repr(value)


BIG = 10**5000   # more digits than int() and repr() take (sys.get_int_max_str_digits)
REPLENISHMENT = {"base": "replenishment"}


@pytest.mark.parametrize("call, fragments", [
    (lambda: dronefleet.run("replenishment", trials=nested(5000)), ["trials[0][0]", "deep"]),
    (lambda: dronefleet.run("replenishment", trials=holding_itself()), ["trials[0][0]", "deep"]),
    (lambda: dronefleet.run(set={"orders.tau_minutes": {"a": nested(5000)}}), ["orders.tau_minutes.a[0]"]),
    (lambda: dronefleet.run("replenishment", trials=BIG), ["run.trials = an integer of 16610 bits"]),
    (lambda: dronefleet.run(seed=BIG), ["run.seed = an integer of 16610 bits"]),
    (lambda: dronefleet.run("replenishment", work_ratio=math.nan), ["work_ratio = nan"]),
    (lambda: dronefleet.run("replenishment", work_ratio=-math.inf), ["work_ratio = -inf"]),
    (lambda: dronefleet.run("replenishment", worker_capacity=10**400), ["worker_capacity"]),
    (lambda: dronefleet.run("replenishment", trials={1, 2}), ["run.trials must be an integer, got set"]),
    (lambda: dronefleet.run("replenishment", trials=b"1"), ["run.trials must be an integer, got bytes"]),
    (lambda: dronefleet.run("replenishment", strategy="x" * 10**6), ["robots.strategy = 'xxx"]),
    (lambda: dronefleet.run(set={"x" * 10**6: 1}), ["unknown key 'xxx"]),
    (lambda: dronefleet.run(set={1: 2}), ["config key 1 is not a string"]),
    (lambda: dronefleet.run("bad\0name.toml"), ["'bad\\x00name.toml'", "NUL"]),
    (lambda: dronefleet.run(b"paper.toml"), ["config=b'paper.toml'"]),
    (lambda: dronefleet.sweep({1: [1]}, **REPLENISHMENT), ["[grid]: key 1 is not a string"]),
    (lambda: dronefleet.sweep({None: [1]}, **REPLENISHMENT), ["[grid]: key None is not a string"]),
    (lambda: dronefleet.sweep({b"trials": [1]}, **REPLENISHMENT), ["[grid]: key b'trials' is not a string"]),
    (lambda: dronefleet.sweep({("trials",): [1]}, **REPLENISHMENT), ["key ('trials',) is not a string"]),
    (lambda: dronefleet.sweep({"run": {1: [1]}}, **REPLENISHMENT), ["[grid]: key 1 is not a string"]),
    (lambda: dronefleet.sweep({"trials": [1]}, set={1: 2}, **REPLENISHMENT), ["[set]: key 1 is not a string"]),
    (lambda: dronefleet.sweep({"trials": [nested(5000)]}, **REPLENISHMENT), ["grid.trials[0][0]", "deep"]),
    (lambda: dronefleet.sweep({"trials": [holding_itself()]}, **REPLENISHMENT), ["grid.trials[0][0]", "deep"]),
    (lambda: dronefleet.sweep({"trials": [1]}, set={"ticks": nested(5000)}, **REPLENISHMENT), ["set.ticks[0]"]),
    (lambda: dronefleet.sweep({"trials": [BIG]}, **REPLENISHMENT), ["trials = an integer of 16610 bits"]),
    (lambda: dronefleet.sweep({"trials": [1]}, set={"ticks": BIG}, **REPLENISHMENT),
     ["run.ticks = an integer of 16610 bits"]),
    (lambda: dronefleet.sweep({"trials": [1]}, seeds=[BIG], base="items"), ["run.seed = an integer of 16610 bits"]),
    (lambda: dronefleet.sweep({"trials": [1]}, seeds=[math.nan], base="items"), ["run.seed", "nan"]),
    (lambda: dronefleet.sweep({"trials": [1]}, seeds=[BIG], **REPLENISHMENT),
     ["seeds=[an integer of 16610 bits] does not apply to a replenishment run"]),
    (lambda: dronefleet.sweep({"trials": [1]}, base="bad\0name.toml"), ["'bad\\x00name.toml'", "NUL"]),
    (lambda: dronefleet.sweep({"work_ratio": [math.inf]}, **REPLENISHMENT), ["work_ratio = inf"]),
    (lambda: dronefleet.sweep({"work_ratio": {1.0, 2.0}}, **REPLENISHMENT), ["work_ratio must be a list"]),
    (lambda: dronefleet.sweep({"strategy": ["x" * 10**6]}, **REPLENISHMENT), ["strategy = 'xxx"]),
    (lambda: dronefleet.sweep({"transfer_loss": [0.0, -0.0]}, **REPLENISHMENT), ["lists -0.0 more than once"]),
    (lambda: dronefleet.sweep({"ticks": [[1] * 10**6]}, **REPLENISHMENT), ["must be an integer, got list"]),
    (lambda: dronefleet.run(scaler_mean=np.zeros((3, 3))), ["scaler_mean", "ndarray"]),  # numpy's repr: lines
    (lambda: dronefleet.run(rule="\x1b[2Jx\ny"), ["'\\x1b[2Jx\\ny'"]),
], ids=lambda value: None if callable(value) else "")
def test_hostile_api_arguments_are_one_line_config_errors_naming_them(call, fragments):
    with pytest.raises(ConfigError) as error:
        call()
    message = str(error.value)
    assert message.isprintable() and len(message) < 1000, message[:2000]
    assert all(fragment in message for fragment in fragments), message


def test_repeated_lists_are_found_without_comparing_every_pair():
    # 30,000 lists compared pairwise took 14 s; 100,000 (the cap) hung
    Counted.comparisons = 0
    values = [[Counted(n)] for n in range(2000)]
    assert sw._repeated(values) is None
    assert Counted.comparisons < len(values)


@pytest.mark.parametrize("values, repeated", [
    ([[1], [1.0]], [1.0]), ([[1], [True]], [True]), ([[1, [2]], [1, [2.0]]], [1, [2.0]]),
    ([[1], (1,)], None), ([[1], [1, 1]], None), ([{"a": [1]}, {"a": [1.0]}], {"a": [1.0]}),
    ([{"a": 1}, {"a": 2}], None), ([[0.0], [-0.0]], [-0.0]), ([1, True], True), ([[], ()], None),
])
def test_repeated_values_are_those_python_finds_equal(values, repeated):
    assert sw._repeated(values) == repeated


# --------------------------------------------------------------------------- replenishment limits

def extremes():
    """(key, value) of every number of the replenishment scenario at its lowest and highest allowed."""
    from dronefleet.replenishment.params import UPPER_LIMITS

    lowest = {"worker_capacity": math.ulp(0.0), "charger_capacity_factor": math.ulp(0.0),
              "work_ratio": math.ulp(0.0), "charge_rate": math.ulp(0.0), "transfer_loss": 0.0,
              "trials": 1, "ticks": 1, "sample_every": 1}
    highest = {**{name: most for name, (most, _) in UPPER_LIMITS.items()},
               "transfer_loss": math.nextafter(1.0, 0.0)}
    return [(key, value) for key in lowest for value in (lowest[key], highest[key])]


@pytest.mark.parametrize("strategy", ["fixed", "mobile"])
@pytest.mark.parametrize("key, value", extremes())
def test_every_number_at_its_limits_gives_finite_bounds_without_a_warning(capsys, strategy, key, value):
    import warnings

    from dronefleet.replenishment import BoundUndefinedError, constant_supply_bounds, fixed_bounds
    from dronefleet.replenishment.scenario import load, replace

    n_chargers = 0 if strategy == "fixed" else 1
    small = {"trials": 1, "ticks": 1, "n_workers": 1, "sample_every": 10**8} if key in ("ticks", "trials") else {}
    config = replace(load(), {"strategy": strategy, "n_chargers": n_chargers, **small, key: value})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for bound in (fixed_bounds, constant_supply_bounds):
            try:
                found = bound(config.params)
            except BoundUndefinedError:  # refused in one line, as `dronefleet bounds` says it
                continue
            assert all(math.isfinite(x) for x in vars(found).values()), (bound.__name__, found)


@pytest.mark.parametrize("key, value", [(k, v) for k, v in extremes() if k not in ("trials", "ticks")])
def test_a_short_run_at_each_limit_is_finite_without_a_warning(key, value):
    import warnings

    import numpy as np

    from dronefleet.replenishment.scenario import load, replace, simulate

    config = replace(load(), {"trials": 1, "ticks": 200, "n_chargers": 2, key: value})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tables = simulate(config)
    for table in tables.values():
        for column in table.column_names:
            assert np.isfinite(np.asarray(table.column(column).to_pylist(), dtype=float)).all(), column


@pytest.mark.parametrize("key, value", [("worker_capacity", 1e308), ("work_ratio", 1e308), ("charge_rate", 1e7),
                                        ("charger_capacity_factor", 1e308), ("ticks", 10**8 + 1),
                                        ("trials", 10**5 + 1), ("sample_every", 10**8 + 1)])
def test_numbers_above_their_limits_are_refused_naming_them(capsys, key, value):
    from dronefleet.replenishment.params import UPPER_LIMITS

    refused(capsys, ["bounds", str(REPLENISHMENT_TOML), "--set", f"{key}={value}"],
            f"{key} = ", f"must be <= {UPPER_LIMITS[key][0]:g}")


# --------------------------------------------------------------------------- run size, per trial too


@pytest.fixture
def no_work(monkeypatch):
    """Any seeding or simulating fails the test: refusals come before any work."""
    import importlib

    simulate = importlib.import_module("dronefleet.replenishment.simulate")
    monkeypatch.setattr(simulate, "spawn_states", lambda *args: pytest.fail("trials were seeded"))
    monkeypatch.setattr(simulate.kernel, "run_trials", lambda *args: pytest.fail("the kernel ran"))


@pytest.mark.parametrize("changes, fragments", [
    # 5e6 one-tick trials passed (3.5e7 robot-ticks) and then seeded for minutes in ~3 GB
    ({"trials": 5_000_000, "ticks": 1}, ["trials = 5000000", "must be <= 100000"]),
    # 9.6e8 robot-ticks of ticks, and 1e5 trials' set-ups on top
    ({"trials": 100_000, "ticks": 800, "sample_every": 800},
     ["robot-ticks", "trials 100000", "ticks 800 x 12 robots", "per trial's set-up", "at most 1e+09"]),
    ({"trials": 50_000, "ticks": 2000, "n_chargers": 1}, ["GB", "trials 50000", "201 time-series rows", "2 GB"]),
    ({"trials": 100, "ticks": 150_000, "sample_every": 1}, ["GB", "150001 time-series rows", "sample_every"]),
    ({"trials": 1000, "ticks": 100_000, "sample_every": 100}, ["robot-ticks", "lower trials or ticks"]),
])
def test_a_run_too_large_counting_each_trials_set_up_is_refused_before_any_work(tmp_path, capsys, no_work,
                                                                               changes, fragments):
    args = [arg for key, value in changes.items() for arg in ("--set", f"{key}={value}")]
    refused(capsys, ["run", str(REPLENISHMENT_TOML), *args, "--out", str(tmp_path / "out")], *fragments)
    assert not (tmp_path / "out").exists()
    with pytest.raises(ConfigError, match=re.escape(fragments[-1])):
        dronefleet.run("replenishment", **changes)


def test_each_grid_cell_of_a_sweep_is_held_to_the_run_limits_before_the_sweep_starts(tmp_path, capsys, no_work):
    path = tmp_path / "cells.toml"
    path.write_text('[sweep]\nscenario = "replenishment"\n[set]\nticks = 800\nsample_every = 800\n[grid]\ntrials = [10, 100000]\n')
    results = tmp_path / "results"
    refused(capsys, ["sweep", "run", str(path), "--results", str(results)], "[grid] at trials = 100000",
            "robot-ticks")
    assert not results.exists()


# --------------------------------------------------------------------------- delivery limits

def test_every_delivery_number_has_a_finite_upper_limit():
    from dronefleet.delivery.config import PARAMETERS

    numbers = {name: p.constraint for name, p in PARAMETERS.items() if p.type in (int, float, tuple)}
    assert all(c.right is not None and math.isfinite(c.right) for c in numbers.values()), numbers


@pytest.mark.parametrize("key", ["tau_minutes", "record_interval_s", "advert_interval_s", "eta0"])
def test_delivery_periods_and_rates_above_their_limits_are_refused(tmp_path, capsys, key):
    # tau_minutes = 1e308 was taken: tau_s = inf
    refused(capsys, ["run", "--set", f"{key}=1e308", "--out", str(tmp_path / "out")], f"{key} = 1e+308",
            "out of range: allowed")


@pytest.mark.parametrize("key", ["tau_minutes", "record_interval_s", "advert_interval_s", "eta0"])
def test_a_short_delivery_run_at_each_new_limit_is_finite_without_a_warning(key):
    import warnings

    from dronefleet.delivery.config import PARAMETERS

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        summary = dronefleet.run(horizon_weeks=0.02, n_uavs=3, **{key: PARAMETERS[key].constraint.right}).summary
    assert summary.orders_arrived.iloc[0] >= 0 and math.isfinite(summary.backlog_age_s.iloc[0])


# --------------------------------------------------------------------------- output paths

@pytest.mark.parametrize("name, reason", [("x" * 5000, "File name too long"), ("bad\0name", "NUL byte")])
def test_an_out_folder_no_file_system_can_name_is_refused_in_one_line(tmp_path, capsys, name, reason):
    if "\0" not in name:  # argv cannot hold a NUL byte
        refused(capsys, ["run", str(REPLENISHMENT_TOML), "--set", "trials=1", "--set", "ticks=10",
                         "--out", str(tmp_path / name)], "--out '", "cannot name a folder")
    run = dronefleet.run("replenishment", trials=1, ticks=10)
    with pytest.raises(ConfigError, match="cannot name a folder"):
        run.save(tmp_path / name)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("head, fragment", [
    (f'name = "{"x" * 100_000}"', "name = 'xxx"), (f"runs_per_task = {'9' * 100_000}", "cannot parse"),
    (f'runs_per_task = "{"x" * 100_000}"', "runs_per_task must be an integer >= 1, got 'xxx"),
    (f"base = [{', '.join(['1'] * 100_000)}]", "base must be a path (string), got [1, 1"),
])
def test_sweep_heads_of_huge_values_are_refused_in_a_short_line(tmp_path, capsys, head, fragment):
    path = tmp_path / "huge.toml"
    path.write_text(f'[sweep]\nscenario = "replenishment"\n{head}\n[grid]\nticks = [10]\n')
    refused(capsys, ["sweep", "plan", str(path), "--results", str(tmp_path / "results")], fragment)


def test_grid_keys_of_huge_integers_are_named_in_a_short_line():
    with pytest.raises(ConfigError, match="more than 100,000 values|not a string") as error:
        dronefleet.sweep({BIG: range(10**6)}, base="replenishment")
    assert len(str(error.value)) < 1000
