"""Tests of the delivery config (dronefleet.delivery.config on the shared dronefleet.config): files,
overrides, validation messages, JSON."""

import dataclasses
import json
import math
import tomllib
from pathlib import Path

import pytest

from dronefleet.config import ConfigError
from dronefleet.delivery.config import (
    SECTIONS,
    Config,
    config_from_dict,
    default_config,
    load_config,
    replace,
)

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
PAPER = CONFIGS / "paper.toml"
REFERENCE = CONFIGS / "reference-code.toml"

SECTION_OF = {key: section for section, keys in SECTIONS.items() for key in keys}


def write(tmp_path, text, name="run.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def with_value(key, value):
    """Default nested dict with one value changed."""
    d = default_config().to_dict()
    d[SECTION_OF[key]][key] = value
    return d


# --------------------------------------------------------------------------
# Declarations and defaults
# --------------------------------------------------------------------------


def test_sections_in_declared_order_and_keys_unique():
    assert list(SECTIONS) == ["run", "orders", "fleet", "energy", "auction", "policy"]
    assert SECTIONS["run"] == ("seed", "horizon_weeks", "record_interval_s", "fleet_file")
    assert SECTIONS["policy"] == ("alpha", "eta0", "initial_epochs", "scaler_mean", "scaler_std")
    keys = [k for ks in SECTIONS.values() for k in ks]
    assert len(keys) == len(set(keys)) == len(dataclasses.fields(Config))


def test_defaults_are_model_md():
    c = default_config()
    assert (c.seed, c.n_uavs, c.tau_minutes, c.xi, c.initial_epochs) == (0, 25, 15.0, 0.5, 7)
    assert (c.distance_min_m, c.distance_max_m, c.distance_sampling) == (1000.0, 6000.0, "uniform")
    assert (c.soh_min, c.soh_max, c.theta, c.advert_interval_s) == (0.5, 1.0, 50.0, 2.0)
    assert (c.rule, c.base_rule, c.fleet_file) == ("least_confident", "least_confident", "")
    assert c.scaler_mean == (3500.0, 2.75, 50.0)
    assert c.scaler_std == (1443.38, 1.298, 28.87)
    assert c.horizon_s == 4_838_400.0
    assert c.tau_s == 900.0


def test_config_is_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        default_config().n_uavs = 3


# --------------------------------------------------------------------------
# The shipped files
# --------------------------------------------------------------------------


@pytest.mark.parametrize("path", [PAPER, REFERENCE], ids=["paper", "reference-code"])
def test_files_spell_out_every_key_in_its_section(path):
    with open(path, "rb") as fh:
        doc = tomllib.load(fh)
    assert {s: tuple(doc[s]) for s in doc} == SECTIONS


def test_paper_toml_is_the_defaults():
    assert load_config(PAPER) == default_config()
    assert load_config(None) == default_config()


def test_reference_code_toml():
    c = load_config(REFERENCE)
    dmin, dmax = 1000.0, 8000.0
    assert c.distance_sampling == "annulus"
    assert (c.distance_min_m, c.distance_max_m) == (dmin, dmax)
    assert c.scaler_mean == pytest.approx(((dmin + dmax) / 2, 2.75, 75.0), rel=1e-12)
    assert c.scaler_std == pytest.approx(
        ((dmax - dmin) / math.sqrt(12), 4.5 / math.sqrt(12), 50 / math.sqrt(12)), rel=1e-12)
    changed = {"distance_sampling", "distance_max_m", "scaler_mean", "scaler_std"}
    same = {f.name for f in dataclasses.fields(Config)} - changed
    paper = default_config()
    assert {k: getattr(c, k) for k in same} == {k: getattr(paper, k) for k in same}


# --------------------------------------------------------------------------
# Loading: partial files, overrides, seed
# --------------------------------------------------------------------------


def test_partial_file_keeps_defaults_and_ints_become_floats(tmp_path):
    c = load_config(write(tmp_path, "[orders]\ntau_minutes = 20\n"))
    assert c == replace(default_config(), tau_minutes=20.0)
    assert type(c.tau_minutes) is float


@pytest.mark.parametrize("override, key, expected", [
    ("orders.tau_minutes=20", "tau_minutes", 20.0),
    ("tau_minutes=20", "tau_minutes", 20.0),
    ("fleet.n_uavs = 10", "n_uavs", 10),
    ("soh_min=0.4", "soh_min", 0.4),
    ("rule=random", "rule", "random"),                    # bare string
    ('auction.rule="threshold"', "rule", "threshold"),    # quoted TOML string
    ("scaler_mean=[1, 2, 3]", "scaler_mean", (1.0, 2.0, 3.0)),
    ("distance_sampling=annulus", "distance_sampling", "annulus"),
])
def test_override_forms(override, key, expected):
    c = load_config(overrides=[override])
    assert getattr(c, key) == expected
    assert type(getattr(c, key)) is type(expected)
    assert c == replace(default_config(), **{key: expected})


def test_overrides_apply_over_file_and_a_key_given_twice_is_refused(tmp_path):
    path = write(tmp_path, "[run]\nseed = 3\n[fleet]\nn_uavs = 5\n")
    c = load_config(path, overrides=["fleet.n_uavs=9"], seed=11)
    assert (c.n_uavs, c.seed) == (9, 11)
    with pytest.raises(ConfigError, match=r"^n_uavs is given twice \(as --set n_uavs=7 and as --set fleet.n_uavs=9\)"):
        load_config(path, overrides=["n_uavs=7", "fleet.n_uavs=9"])
    with pytest.raises(ConfigError, match=r"^seed is given twice \(as --set seed=4 and as --seed 11\)"):
        load_config(path, overrides=["seed=4"], seed=11)
    assert load_config(path, overrides=["seed=4"]).seed == 4
    assert load_config(path).seed == 3
    assert load_config(seed=5) == replace(default_config(), seed=5)


# --------------------------------------------------------------------------
# Unknown names
# --------------------------------------------------------------------------


def test_unknown_key_in_file_named_with_close_match(tmp_path):
    path = write(tmp_path, "[orders]\ntau_minute = 20\n")
    with pytest.raises(ConfigError) as e:
        load_config(path)
    msg = str(e.value)
    assert "orders.tau_minute " in msg and "did you mean 'tau_minutes'" in msg
    assert str(path) in msg
    assert "distance_sampling" in msg          # lists the allowed keys of [orders]


@pytest.mark.parametrize("override, named, suggested", [
    ("tau_minute=20", "'tau_minute'", "tau_minutes"),
    ("orders.tau_minute=20", "orders.tau_minute", "tau_minutes"),
    ("fleet.nuavs=3", "fleet.nuavs", "n_uavs"),
    ("speed=12", "'speed'", "speed_m_s"),          # unit suffix left off, not 'seed'
    ("tau=20", "'tau'", "tau_minutes"),
])
def test_unknown_key_in_override(override, named, suggested):
    with pytest.raises(ConfigError, match=f"{named}.*did you mean '{suggested}'"):
        load_config(overrides=[override])


def test_key_in_wrong_section_names_the_right_one(tmp_path):
    with pytest.raises(ConfigError, match=r"orders\.n_uavs .*belongs in \[fleet\]"):
        load_config(write(tmp_path, "[orders]\nn_uavs = 3\n"))
    with pytest.raises(ConfigError, match=r"put it in section \[fleet\]"):
        load_config(write(tmp_path, "n_uavs = 3\n"))


def test_unknown_section(tmp_path):
    with pytest.raises(ConfigError) as e:
        load_config(write(tmp_path, "[order]\ntau_minutes = 20\n"))
    msg = str(e.value)
    assert "[order]" in msg and "did you mean 'orders'" in msg
    assert "run, orders, fleet, energy, auction, policy" in msg
    with pytest.raises(ConfigError, match=r"unknown section 'flet'.*did you mean 'fleet'"):
        load_config(overrides=["flet.n_uavs=3"])
    with pytest.raises(ConfigError, match=r"unknown section \[order\]"):
        config_from_dict({"order": {}})


def test_replace_unknown_name():
    with pytest.raises(ConfigError, match="'n_uav'.*did you mean 'n_uavs'"):
        replace(default_config(), n_uav=3)


def test_unknown_rule_lists_registered_rules():
    from dronefleet.delivery.auction import RULES

    with pytest.raises(ConfigError) as e:
        load_config(overrides=["rule=least_confidnt"])
    msg = str(e.value)
    assert "auction.rule = 'least_confidnt' is not a registered winner rule" in msg
    assert "did you mean 'least_confident'" in msg
    assert len(RULES) >= 4
    for name in RULES:
        assert repr(name) in msg
    for name in RULES:                       # every registered rule is accepted
        assert load_config(overrides=[f"rule={name}"]).rule == name


@pytest.mark.parametrize("base", ["threshold", "reservation"])
def test_reservation_base_rule_must_bid_on_its_policy(base):
    with pytest.raises(ConfigError) as e:
        load_config(overrides=["rule=reservation", f"base_rule={base}"])
    msg = str(e.value)
    assert f"auction.base_rule = '{base}' is not a rule that bids on its policy" in msg
    assert "Allowed: 'least_confident', 'most_confident', 'random'" in msg
    assert load_config(overrides=["rule=reservation", "base_rule=random"]).base_rule == "random"


def test_fleet_file_is_any_path_checked_when_used():
    assert load_config(overrides=["fleet_file=runs/seed={seed}/fleet.parquet"]).fleet_file == \
        "runs/seed={seed}/fleet.parquet"
    with pytest.raises(ConfigError, match="run.fleet_file must be a string"):
        load_config(overrides=["fleet_file=3"])


# --------------------------------------------------------------------------
# Types and ranges
# --------------------------------------------------------------------------


@pytest.mark.parametrize("key, value, fragment", [
    ("tau_minutes", "abc", "orders.tau_minutes must be a number, got str 'abc'"),
    ("speed_m_s", True, "energy.speed_m_s must be a number, got bool True"),
    ("n_uavs", True, "fleet.n_uavs must be an integer, got bool True"),
    ("seed", False, "run.seed must be an integer, got bool False"),
    ("n_uavs", 7.5, "fleet.n_uavs must be an integer, got float 7.5"),
    ("initial_epochs", 7.0, "policy.initial_epochs must be an integer, got float 7.0 (write 7)"),
    ("n_uavs", "25", "fleet.n_uavs must be an integer, got str '25'"),
    ("scaler_mean", [1.0, 2.0], "policy.scaler_mean must be a list of 3 numbers, got a list of length 2"),
    ("scaler_std", [1.0, 2.0, 3.0, 4.0], "policy.scaler_std must be a list of 3 numbers, got a list of length 4"),
    ("scaler_mean", 3.0, "policy.scaler_mean must be a list of 3 numbers, got float 3.0"),
    ("scaler_mean", [1.0, "x", 3.0], "policy.scaler_mean[1] must be a number, got str 'x'"),
    ("distance_sampling", 1, "orders.distance_sampling must be a string, got int 1"),
    ("rule", None, "auction.rule must be a string, got NoneType None"),
])
def test_wrong_type(key, value, fragment):
    with pytest.raises(ConfigError) as e:
        config_from_dict(with_value(key, value))
    assert fragment in str(e.value)
    assert key in e.value.keys


@pytest.mark.parametrize("key, value, allowed", [
    ("tau_minutes", -15.0, "(0, 1.008e+07]"),
    ("tau_minutes", 0, "(0, 1.008e+07]"),
    ("soh_min", 0, "(0, 1]"),
    ("soh_min", 1.5, "(0, 1]"),
    ("soh_max", 0.0, "(0, 1]"),
    ("xi", 1.0, "[0, 1)"),
    ("xi", -0.1, "[0, 1)"),
    ("n_uavs", 0, "[1, 32767]"),
    ("n_uavs", 32768, "[1, 32767]"),
    ("speed_m_s", -10.0, "(0, 10000]"),
    ("speed_m_s", 1e300, "(0, 10000]"),
    ("theta", 101, "[0, 100]"),
    ("theta", -1.0, "[0, 100]"),
    ("charger_efficiency", 1.01, "[0.01, 1]"),
    ("charger_efficiency", 1e-300, "[0.01, 1]"),
    ("seed", -1, "[0, 9223372036854775807]"),
    ("seed", 2**63, "[0, 9223372036854775807]"),
    ("charger_power_w", 1e-300, "[1, 1e+06]"),
    ("capacity_wh", 1e7, "[1, 1e+06]"),
    ("advert_interval_s", 1e-6, "[0.001, 6.048e+08]"),
    ("mass_min_kg", -0.5, "[0, 10000]"),
    ("frame_mass_kg", 1e300, "[0, 10000]"),
    ("distance_min_m", 0.0, "(0, 1e+07]"),
    ("alpha", 1e300, "(0, 100]"),
    ("horizon_weeks", 0.0, "(0, 1000]"),
    ("horizon_weeks", 1e6, "(0, 1000]"),
    ("scaler_std", [1.0, 0.0, 1.0], "[1e-06, 1e+09]"),
])
def test_out_of_range(key, value, allowed):
    with pytest.raises(ConfigError) as e:
        config_from_dict(with_value(key, value))
    msg = str(e.value)
    qualname = f"{SECTION_OF[key]}.{key}"
    shown = f"{qualname}[1] = 0.0" if key == "scaler_std" else f"{qualname} = {value!r}"
    assert msg == f"{shown} is out of range: allowed {allowed}"


def test_out_of_range_message_example():
    with pytest.raises(ConfigError) as e:
        replace(default_config(), soh_min=1.5)
    assert str(e.value) == "fleet.soh_min = 1.5 is out of range: allowed (0, 1]"


@pytest.mark.parametrize("key, value", [
    ("xi", 0.0), ("soh_min", 1.0), ("soh_max", 1.0), ("theta", 0), ("theta", 100),
    ("charger_efficiency", 1.0), ("mass_min_kg", 0.0), ("seed", 0), ("n_uavs", 1),
    ("scaler_mean", [-1.0, 0, 1e9]),
])
def test_range_boundaries_accepted(key, value):
    c = config_from_dict(with_value(key, value))
    expected = tuple(float(v) for v in value) if isinstance(value, list) else value
    assert getattr(c, key) == expected


@pytest.mark.parametrize("value", [math.inf, -math.inf, math.nan])
def test_non_finite_floats_rejected(value):
    with pytest.raises(ConfigError, match="orders.tau_minutes = .* is not a finite number"):
        replace(default_config(), tau_minutes=value)
    with pytest.raises(ConfigError, match=r"policy.scaler_mean\[0\]"):
        replace(default_config(), scaler_mean=(value, 1.0, 1.0))


@pytest.mark.parametrize("lo, hi, lo_value, hi_value", [
    ("mass_min_kg", "mass_max_kg", 6.0, 5.0),
    ("distance_min_m", "distance_max_m", 7000.0, 6000.0),
    ("soh_min", "soh_max", 0.9, 0.8),
])
def test_cross_rules(lo, hi, lo_value, hi_value):
    with pytest.raises(ConfigError) as e:
        replace(default_config(), **{lo: lo_value, hi: hi_value})
    section = SECTION_OF[lo]
    assert str(e.value) == (f"{section}.{lo} = {lo_value!r} must be <= "
                            f"{section}.{hi} = {hi_value!r}")
    assert e.value.keys == (lo, hi)
    equal = replace(default_config(), **{lo: hi_value, hi: hi_value})   # equality is fine
    assert getattr(equal, lo) == getattr(equal, hi)


def test_value_errors_name_their_source(tmp_path):
    bad = write(tmp_path, "[fleet]\nsoh_min = 1.5\n", name="bad.toml")
    with pytest.raises(ConfigError) as e:
        load_config(bad)
    assert str(e.value).endswith(f"allowed (0, 1] (set in {bad})")
    path = write(tmp_path, "[fleet]\nsoh_min = 0.9\n")
    with pytest.raises(ConfigError, match=r"set in .*run\.toml; --set soh_max=0.8"):
        load_config(path, overrides=["soh_max=0.8"])
    with pytest.raises(ConfigError, match=r"\(set in --set n_uavs=0\)"):
        load_config(overrides=["n_uavs=0"])
    with pytest.raises(ConfigError, match=r"run.seed must be an integer.*--seed 1.5"):
        load_config(seed=1.5)


def test_validation_on_every_entry_point():
    with pytest.raises(ConfigError, match="fleet.n_uavs"):
        Config(n_uavs=0)
    with pytest.raises(ConfigError, match="fleet.n_uavs"):
        replace(default_config(), n_uavs=0)
    with pytest.raises(ConfigError, match="fleet.n_uavs"):
        config_from_dict({"fleet": {"n_uavs": 0}})
    with pytest.raises(ConfigError, match="fleet.n_uavs"):
        load_config(overrides=["n_uavs=0"])


# --------------------------------------------------------------------------
# Malformed input
# --------------------------------------------------------------------------


@pytest.mark.parametrize("override", ["tau", "=20", "  = 3"])
def test_malformed_override(override):
    with pytest.raises(ConfigError) as e:
        load_config(overrides=[override])
    assert str(e.value) == f"--set needs key=value, got {override!r}"


def test_malformed_override_reported_before_reading_file(tmp_path):
    with pytest.raises(ConfigError, match="--set needs key=value, got 'tau'"):
        load_config(tmp_path / "missing.toml", overrides=["tau"])


def test_override_value_that_is_not_toml_is_a_string_and_then_checked():
    with pytest.raises(ConfigError, match="orders.tau_minutes must be a number, got str '1,5'"):
        load_config(overrides=["tau_minutes=1,5"])


def test_toml_syntax_error_names_the_file(tmp_path):
    path = write(tmp_path, "[orders]\ntau_minutes = = 20\n", name="broken.toml")
    with pytest.raises(ConfigError) as e:
        load_config(path)
    assert f"cannot parse config file {str(path)!r}" in str(e.value)
    assert "line 2" in str(e.value)


def test_missing_file_is_a_config_error(tmp_path):
    path = tmp_path / "nope.toml"
    with pytest.raises(ConfigError, match="cannot read config file .*nope.toml"):
        load_config(path)


def test_section_that_is_not_a_table(tmp_path):
    with pytest.raises(ConfigError, match=r"\[fleet\] must be a table"):
        config_from_dict({"fleet": 3})


# --------------------------------------------------------------------------
# JSON
# --------------------------------------------------------------------------


@pytest.mark.parametrize("make", [
    default_config,
    lambda: load_config(REFERENCE),
    lambda: load_config(overrides=["n_uavs=3", "rule=threshold", "theta=70", "seed=123"]),
], ids=["default", "reference-code", "overrides"])
def test_json_round_trip(make):
    c = make()
    back = config_from_dict(json.loads(c.to_json()))
    assert back == c
    assert back.to_json() == c.to_json()
    d = c.to_dict()
    assert list(d) == list(SECTIONS)
    assert isinstance(d["policy"]["scaler_mean"], list)
    assert json.loads(json.dumps(d)) == d


def test_to_json_deterministic():
    c = load_config(REFERENCE)
    d = c.to_dict()
    reversed_dict = {s: dict(reversed(list(t.items()))) for s, t in reversed(list(d.items()))}
    other = config_from_dict(reversed_dict)
    assert other.to_json() == c.to_json()
    text = c.to_json()
    assert text == json.dumps(json.loads(text), sort_keys=True)
    assert text.index('"auction"') < text.index('"run"')
    assert default_config().to_json() != text


# A run's size: each RUN_LIMITS term just below its limit is accepted, just above refused.
_QUIET = {"tau_minutes": 1e6, "record_interval_s": 1e6, "advert_interval_s": 1e4}  # every other term small
_SIZE_KNOBS = {
    "orders": lambda x: {"horizon_weeks": 8.0, "tau_minutes": 8 * 604800.0 / 60.0 / x},
    "samples": lambda x: {"horizon_weeks": 8.0, "record_interval_s": 8 * 604800.0 / (x - 1.0)},
    "advert_ticks": lambda x: {"horizon_weeks": 8.0, "advert_interval_s": 8 * 604800.0 / x},
    "fleet_rows": lambda x: {"n_uavs": 20000, "horizon_weeks": math.floor(x / 20000) - 1.0},
    "fit_draws": lambda x: {"n_uavs": 1000, "initial_epochs": int(x // 1000)},
}


@pytest.mark.parametrize("term", sorted(_SIZE_KNOBS))
def test_run_size_limits_refuse_just_above_and_accept_at_the_limit(term):
    from dronefleet.delivery.config import RUN_LIMITS, run_size

    limit = RUN_LIMITS[term]
    at = replace(default_config(), **{**_QUIET, **_SIZE_KNOBS[term](limit)})
    assert run_size(at)[term] == pytest.approx(limit, rel=1e-9)
    with pytest.raises(ConfigError) as e:
        replace(default_config(), **{**_QUIET, **_SIZE_KNOBS[term](1.02 * limit)})
    assert str(e.value).startswith(f"the run would hold ~{1.02 * limit:.3g} ")
    assert str(e.value).endswith(f"; at most {limit:g} allowed")


@pytest.mark.parametrize("text, shown", [
    ("array([[0., 0.],\n       [0., 0.]])", "array([[0., 0.], [0., 0.]])"),  # a repr over lines: one line
    ("got '  = 3'", "got '  = 3'"),  # spaces a message quotes are kept
    ("bad\r\n\u2028value\n", "bad value"),
    ("escape \x1b[2J\tand tab", "escape \\x1b[2J\\tand tab"),  # what a terminal would act on, shown
])
def test_a_config_error_is_one_line_of_printable_text(text, shown):
    assert str(ConfigError(text)) == shown
