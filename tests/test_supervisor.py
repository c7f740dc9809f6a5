"""Tests of dronefleet.supervisor against the nine published Nadzoru 2 files in tests/data."""

from pathlib import Path

import numpy as np
import pytest

from dronefleet.supervisor import (
    BUILTIN_CONTROLLER,
    SupervisorError,
    SupervisorFileError,
    SupervisorVM,
    load_supervisor,
    take,
)

#: Copies of the published Nadzoru 2 exports (their README says where each comes from).
MODELS = Path(__file__).resolve().parent / "data" / "sct-models"

# The table of tests/data/sct-models/README.md:
# file -> (events, supervisors, sum of local states, transitions, bytes).
README_COUNTS = {
    "uav-delivery-controller.yaml": (9, 1, 6, 39, 1022),
    "multi-human-swarm-leader.yaml": (10, 5, 10, 39, 1143),
    "multi-human-swarm-worker.yaml": (35, 10, 154, 762, 14335),
    "energy-replenishment-worker.yaml": (10, 4, 32, 124, 3051),
    "energy-replenishment-worker-with-mobile-charger.yaml": (10, 4, 32, 124, 3051),
    "energy-replenishment-charger.yaml": (13, 4, 45, 279, 6432),
    "replenishment-2024-worker.yaml": (10, 4, 32, 124, 2590),
    "replenishment-2024-worker-with-mobile-charger.yaml": (10, 4, 30, 150, 3029),
    "replenishment-2024-charger.yaml": (10, 4, 32, 124, 2646),
}

REQUIRED_KEYS = ["num_events", "num_supervisors", "events", "ev_controllable", "sup_events",
                 "sup_init_state", "sup_current_state", "sup_data_pos", "sup_data"]


@pytest.fixture(scope="module")
def uav():
    return load_supervisor(BUILTIN_CONTROLLER)


def column(automaton, name):
    return automaton.events.index(name)


# --------------------------------------------------------------------------- real files


@pytest.mark.parametrize("name", sorted(README_COUNTS))
def test_counts_match_readme(name):
    path = MODELS / name
    n_events, n_supervisors, n_states, n_transitions, n_bytes = README_COUNTS[name]
    assert path.stat().st_size == n_bytes
    a = load_supervisor(path)
    assert (a.n_events, a.n_supervisors, sum(a.n_states), a.n_transitions) == (
        n_events, n_supervisors, n_states, n_transitions)
    assert a.controllable.shape == a.shared.shape == (n_events,)
    assert a.alphabet.shape == (n_supervisors, n_events)
    assert a.init_state.dtype == np.int64 and a.init_state.shape == (n_supervisors,)


def test_packaged_controller_is_the_shared_file():
    assert BUILTIN_CONTROLLER.read_bytes() == (MODELS / "uav-delivery-controller.yaml").read_bytes()


def test_uav_controller_table(uav):
    assert uav.events == ("lostBid", "notCapableTask", "notCondReturn", "condReturn", "capableTask",
                          "bid", "deliver", "wonBid", "return")
    assert {e for e, c in zip(uav.events, uav.controllable) if c} == {"bid", "deliver", "return"}
    assert not uav.shared.any()
    table = uav.transition_table(uav.events)
    assert table.shape == (1, 6, 9) and table.dtype == np.int64
    chain = [(0, "capableTask", 1), (1, "bid", 2), (2, "wonBid", 3), (3, "deliver", 4),
             (4, "condReturn", 5), (5, "return", 0),
             (1, "notCapableTask", 0), (2, "lostBid", 0), (5, "notCondReturn", 4)]
    for source, event, target in chain:
        assert table[0, source, column(uav, event)] == target, (source, event)
    assert table[0, 0, column(uav, "bid")] == -1
    assert (table[0, :, column(uav, "return")] == [-1, -1, -1, -1, -1, 0]).all()


def test_transition_table_follows_requested_columns(uav):
    table = uav.transition_table(["return", "capableTask"])
    assert table.shape == (1, 6, 2)
    assert table[0, 5, 0] == 0 and table[0, 0, 0] == -1
    assert table[0, 0, 1] == 1


def test_event_outside_alphabet_stays_put():
    a = load_supervisor(MODELS / "energy-replenishment-charger.yaml")
    assert a.n_states == (10, 10, 10, 15)
    table = a.transition_table(["atCharger", "rest"])
    # atCharger is watched by supervisors 2 and 3 only.
    assert not a.alphabet[0, column(a, "atCharger")] and not a.alphabet[1, column(a, "atCharger")]
    for k in (0, 1):
        assert (table[k, :10, 0] == np.arange(10)).all()
        assert (table[k, 10:, 0] == -1).all()  # rows past the supervisor's 10 states
    assert table[3, 1, 0] == 3  # "EV_atCharger, 0, 3" in state 1 of the last supervisor
    assert (table[:, :, 1] >= -1).all() and (table[0, :10, 1] != np.arange(10)).any()


def test_unknown_event_name_raises(uav):
    with pytest.raises(SupervisorFileError, match="'fly'.*capableTask") as info:
        uav.transition_table(["bid", "fly"])
    assert "EV_" not in str(info.value)


# --------------------------------------------------------------------------- take


def test_take_moves_only_the_row_of_an_allowed_event(uav):
    table = uav.transition_table(["capableTask", "bid"])
    states = np.zeros((3, 1), dtype=np.int64)
    assert take(table, states, 1, 0)
    assert states[:, 0].tolist() == [0, 1, 0]
    assert take(table, states, 1, 1)
    assert states[:, 0].tolist() == [0, 2, 0]


def test_take_refuses_a_disallowed_event(uav):
    table = uav.transition_table(["bid"])
    states = np.array([[0], [1]], dtype=np.int64)
    assert not take(table, states, 0, 0)
    assert states[:, 0].tolist() == [0, 1]


def test_take_is_atomic_over_supervisors():
    a = load_supervisor(MODELS / "energy-replenishment-charger.yaml")
    table = a.transition_table(["rest", "atCharger"])
    states = np.tile(a.init_state, (2, 1))
    assert states[1].tolist() == [8, 0, 8, 1]
    # From the initial states supervisor 3 forbids rest while 0, 1 and 2 would move on it.
    assert table[:, :, 0][np.arange(4), states[1]].tolist() == [5, 8, 6, -1]
    assert not take(table, states, 1, 0)
    assert states.tolist() == [[8, 0, 8, 1]] * 2
    assert take(table, states, 1, 1)
    assert states.tolist() == [[8, 0, 8, 1], [8, 0, 8, 3]]


# --------------------------------------------------------------------------- virtual machine


def test_vm_walks_a_delivery_cycle(uav):
    vm = SupervisorVM(uav, np.random.default_rng(1))
    inputs = dict.fromkeys(["lostBid", "notCapableTask", "notCondReturn", "condReturn", "capableTask",
                            "wonBid"], False)
    log = []
    for event in inputs:
        vm.on_input(event, lambda event=event: inputs[event])
    for event in uav.events:
        vm.on_event(event, lambda event=event: log.append(event))

    assert vm.state == (0,) and vm.step() is None and log == []
    for fire, chosen, state in [("capableTask", "bid", 2), ("wonBid", "deliver", 4), ("condReturn", "return", 0)]:
        inputs[fire] = True
        assert vm.step() == chosen
        inputs[fire] = False
        assert vm.state == (state,)
    assert log == ["capableTask", "bid", "wonBid", "deliver", "condReturn", "return"]

    # Fired inputs are applied in event-index order: notCapableTask (1) before capableTask (4);
    # the other order would end in S0 with nothing enabled.
    log.clear()
    inputs["notCapableTask"] = inputs["capableTask"] = True
    assert vm.step() == "bid"
    assert log == ["notCapableTask", "capableTask", "bid"] and vm.state == (2,)


def test_vm_trigger(uav):
    vm = SupervisorVM(uav)
    log = []
    vm.on_event("bid", lambda: log.append("bid"))
    with pytest.raises(SupervisorError, match="'bid'.*supervisor 0 in state 0"):
        vm.trigger("bid")
    assert vm.state == (0,) and log == []
    for event, state in [("capableTask", 1), ("bid", 2), ("wonBid", 3), ("deliver", 4), ("condReturn", 5),
                         ("notCondReturn", 4)]:
        vm.trigger(event)
        assert vm.state == (state,)
    assert log == ["bid"]
    assert vm.enabled() == []
    vm.trigger("condReturn")
    assert vm.enabled() == ["return"]


def test_vm_input_checks_only_for_uncontrollable_known_events(uav):
    vm = SupervisorVM(uav)
    with pytest.raises(ValueError, match="'bid' is controllable"):
        vm.on_input("bid", lambda: True)
    with pytest.raises(SupervisorFileError, match="'fly'"):
        vm.on_input("fly", lambda: True)
    with pytest.raises(SupervisorFileError, match="'fly'"):
        vm.trigger("fly")


def test_vm_trigger_is_atomic_over_supervisors():
    vm = SupervisorVM(load_supervisor(MODELS / "energy-replenishment-charger.yaml"))
    ran = []
    vm.on_event("rest", lambda: ran.append("rest"))
    # Supervisors 0, 1 and 2 have a transition on rest; supervisor 3 has none.
    with pytest.raises(SupervisorError, match="'rest'.*supervisor 3 in state 1") as info:
        vm.trigger("rest")
    assert "supervisor 0" not in str(info.value)
    assert vm.state == (8, 0, 8, 1) and ran == []


def test_vm_outside_alphabet_stays_put():
    vm = SupervisorVM(load_supervisor(MODELS / "energy-replenishment-charger.yaml"))
    assert vm.state == (8, 0, 8, 1)
    vm.trigger("atCharger")  # alphabet of supervisors 2 and 3 only
    assert vm.state == (8, 0, 8, 3)
    vm.trigger("timeToWork")  # not in supervisor 2's alphabet; supervisor 0 goes 8 -> 7
    assert vm.state == (7, 0, 8, 3)


def test_vm_step_chooses_among_enabled_with_the_rng():
    leader = load_supervisor(MODELS / "multi-human-swarm-leader.yaml")

    def choose(seed):
        vm = SupervisorVM(leader, np.random.default_rng(seed))
        vm.trigger("pressStop")
        vm.trigger("pressStart")
        assert vm.state == (1, 1, 0, 0, 0) and vm.enabled() == ["stop", "start"]
        chosen = vm.step()
        expected_state = {"stop": (1, 0, 0, 0, 0), "start": (0, 1, 0, 0, 0)}[chosen]
        assert vm.state == expected_state
        return chosen

    choices = [choose(seed) for seed in range(40)]
    assert choices == [choose(seed) for seed in range(40)]
    assert set(choices) == {"stop", "start"}
    assert choices == [["stop", "start"][np.random.default_rng(seed).integers(2)] for seed in range(40)]


# --------------------------------------------------------------------------- bad files


def edit(key, old, new):
    """An edit of the UAV file: replace ``old`` by ``new`` once, in the line of ``key``."""
    def apply(lines):
        (i,) = [i for i, line in enumerate(lines) if line.startswith(f"{key}:")]
        assert lines[i].count(old) == 1, (key, old)
        lines[i] = lines[i].replace(old, new)
        return lines
    return apply


def write_bad(tmp_path, change):
    lines = change(BUILTIN_CONTROLLER.read_text().splitlines())
    path = tmp_path / "bad.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("key", REQUIRED_KEYS)
def test_missing_key(tmp_path, key):
    path = write_bad(tmp_path, lambda lines: [line for line in lines if not line.startswith(f"{key}:")])
    with pytest.raises(SupervisorFileError, match=f"missing top-level key.*{key}") as info:
        load_supervisor(path)
    assert str(path) in str(info.value)


BAD_EDITS = {
    "dangling target": (edit("sup_data", "EV_return,0,0 ]", "EV_return,0,9 ]"),
                        ["dangling", "supervisor 0, state 5", "'EV_return'", "state 9", "6 states"]),
    "dangling target via hi": (edit("sup_data", "EV_return,0,0 ]", "EV_return,1,0 ]"),
                               ["dangling", "state 256", "6 states"]),
    "unknown event": (edit("sup_data", "EV_bid,0,2", "EV_bidd,0,2"),
                      ["'EV_bidd'", "supervisor 0, state 1", "not in events"]),
    "events too short": (edit("events", ",EV_return", ""), ["events has 8 entries", "num_events is 9"]),
    "ev_controllable too long": (edit("ev_controllable", "1 ]", "1,0 ]"),
                                 ["ev_controllable has 10 entries", "num_events is 9"]),
    "sup_events row too short": (edit("sup_events", "[ 1,", "["), ["sup_events[0]", "9 flags"]),
    "more supervisors than rows": (edit("num_supervisors", "1", "2"),
                                   ["sup_events has 1 entries", "num_supervisors is 2"]),
    "init state out of range": (edit("sup_init_state", "0", "6"), ["sup_init_state[0] = 6", "6 states"]),
    "truncated sup_data": (edit("sup_data", ",EV_return,0,0 ]", " ]"),
                           ["truncated", "supervisor 0, state 5", "n_out = 7"]),
    "bad n_out": (edit("sup_data", "[ 6,", "[ 5,"), ["n_out", "'EV_wonBid'", "supervisor 0, state 1"]),
}


def test_machine_starts_from_init_state_not_current_state(tmp_path):
    path = write_bad(tmp_path, edit("sup_current_state", "0", "3"))
    a = load_supervisor(path)
    assert a.init_state.tolist() == [0]
    assert SupervisorVM(a).state == (0,)


def test_shared_flags_from_ev_shared_or_ev_public(tmp_path):
    text = (MODELS / "multi-human-swarm-leader.yaml").read_text()
    expected = [False, True, True, False, True, True, True, False, True, False]
    assert load_supervisor(MODELS / "multi-human-swarm-leader.yaml").shared.tolist() == expected
    path = tmp_path / "public.yaml"
    path.write_text(text.replace("ev_shared:", "ev_public:"))
    assert load_supervisor(path).shared.tolist() == expected


@pytest.mark.parametrize("case", sorted(BAD_EDITS))
def test_bad_file(tmp_path, case):
    change, expected = BAD_EDITS[case]
    path = write_bad(tmp_path, change)
    with pytest.raises(SupervisorFileError) as info:
        load_supervisor(path)
    message = str(info.value)
    assert str(path) in message
    for fragment in expected:
        assert fragment in message, (fragment, message)
