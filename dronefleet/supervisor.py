"""Supervisors exported by Nadzoru 2: loader, compiled transition kernel, virtual machine.

A Nadzoru 2 file holds K local supervisors over N events. Each supervisor has
an alphabet (the events it watches) and a deterministic transition function.
An event may happen only if every supervisor whose alphabet holds it has a
transition on it from its current state; it then moves all of them at once and
leaves the other supervisors where they are.

- :func:`load_supervisor` validates a file once and returns an :class:`Automaton`.
- :meth:`Automaton.transition_table` compiles it into a dense int64 table.
- :func:`take` applies one event to one UAV's local states inside compiled code.
- :class:`SupervisorVM` is the generic Python machine of the published
  controllers (input checks, callbacks, random choice of a controllable event).
"""

import os
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from .jit import borrowing

from .config import ConfigError, brief

BUILTIN_CONTROLLER = Path(__file__).parent / "data" / "uav-delivery-controller.yaml"

#: Largest supervisor file read [bytes]. Real Nadzoru 2 files are a few KB (the largest
#: known, ~15 KB); the cap keeps parsing to about a second (libyaml: ~4 s per MB).
MAX_FILE_BYTES = 256_000
#: Deepest nesting of lists and mappings read (Nadzoru 2 files nest 3 deep: a mapping of lists of lists).
MAX_DEPTH = 20
#: Largest dense transition table built (K x states x events entries, int64): ~80 MB.
MAX_TABLE_ENTRIES = 10_000_000

# libyaml's parser when PyYAML was built with it (much faster); the pure-Python one otherwise.
_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

_PREFIX = "EV_"

_REQUIRED_KEYS = (
    "num_events",
    "num_supervisors",
    "events",
    "ev_controllable",
    "sup_events",
    "sup_init_state",
    "sup_current_state",
    "sup_data_pos",
    "sup_data",
)


class SupervisorFileError(ConfigError):
    """A supervisor file (or an event name asked of it) is not what Nadzoru 2 writes.

    A ConfigError (so a ValueError): bad input, which the command line reports in one line.
    """


class SupervisorError(RuntimeError):
    """A transition the supervisor does not allow was attempted."""


# --------------------------------------------------------------------------- automaton


# eq=False: the fields hold arrays, so generated __eq__/__hash__ would fail; identity is right.
@dataclass(frozen=True, eq=False)
class Automaton:
    """K local supervisors over N events, as exported by Nadzoru 2.

    Attributes
    ----------
    events : tuple of str, length N
        Event names without the ``EV_`` prefix, in file order (the event index).
    controllable : ndarray, shape (N,), bool
        True for controllable events.
    shared : ndarray, shape (N,), bool
        ``ev_shared`` (or ``ev_public``); all False when the file has neither.
    alphabet : ndarray, shape (K, N), bool
        ``alphabet[k, e]``: supervisor k watches event e (``sup_events``).
    init_state : ndarray, shape (K,), int64
        Initial local state of each supervisor.
    transitions : tuple of dict, length K
        ``transitions[k][(state, event_index)] -> target_state``.
    n_states : tuple of int, length K
        Number of local states of each supervisor.
    """

    events: tuple[str, ...]
    controllable: np.ndarray
    shared: np.ndarray
    alphabet: np.ndarray
    init_state: np.ndarray
    transitions: tuple[dict, ...]
    n_states: tuple[int, ...]

    @property
    def n_events(self) -> int:
        """N, the number of events."""
        return len(self.events)

    @property
    def n_supervisors(self) -> int:
        """K, the number of local supervisors."""
        return len(self.n_states)

    @property
    def n_transitions(self) -> int:
        """Number of transitions, summed over the supervisors."""
        return sum(len(t) for t in self.transitions)

    def event_index(self, name: str) -> int:
        """Index of event ``name`` (without ``EV_``); SupervisorFileError if unknown."""
        try:
            return self.events.index(name)
        except ValueError:
            raise SupervisorFileError(
                f"unknown event {name!r}; the automaton's events are: {', '.join(self.events)}"
            ) from None

    def transition_table(self, events: Sequence[str]) -> np.ndarray:
        """Dense transition table over the events ``events``, in that column order.

        Parameters
        ----------
        events : sequence of str, length E
            Event names without the ``EV_`` prefix; column c is ``events[c]``.

        Returns
        -------
        ndarray, shape (K, max(n_states), E), int64
            ``table[k, s, c]`` is the state supervisor k goes to from state s on
            event ``events[c]``, or -1 where that transition is not allowed. An
            event outside supervisor k's alphabet leaves it in place
            (``table[k, s, c] = s``). Rows ``s >= n_states[k]`` are -1.

        Raises
        ------
        SupervisorFileError
            If a name is not an event of the automaton, or the table would have more
            than MAX_TABLE_ENTRIES entries.
        """
        columns = [self.event_index(name) for name in events]
        size = self.n_supervisors * max(self.n_states) * len(columns)
        if size > MAX_TABLE_ENTRIES:
            raise SupervisorFileError(
                f"the transition table would have {size} entries ({self.n_supervisors} supervisors x "
                f"{max(self.n_states)} states x {len(columns)} events); at most {MAX_TABLE_ENTRIES} allowed")
        table = np.full((self.n_supervisors, max(self.n_states), len(columns)), -1, dtype=np.int64)
        for k, n in enumerate(self.n_states):
            for c, e in enumerate(columns):
                if self.alphabet[k, e]:
                    for s in range(n):
                        table[k, s, c] = self.transitions[k].get((s, e), -1)
                else:
                    table[k, :n, c] = np.arange(n)
        return table


# --------------------------------------------------------------------------- loader


def _error(path, message):
    return SupervisorFileError(f"{path}: {message}")


def _show(value):
    """A value for a message: its repr cut to 60 characters, never a whole parsed structure."""
    try:
        text = repr(value)
    except ValueError:  # an int too long to print (sys.get_int_max_str_digits)
        return f"an integer of {value.bit_length()} bits"
    return text if len(text) <= 60 else f"{text[:57]}... ({type(value).__name__})"


def _read_yaml(path):
    """The YAML document of ``path``, refused unless it is a UTF-8 file of at most MAX_FILE_BYTES.

    The events are scanned before anything is built: aliases are refused (Nadzoru 2 never
    writes them, and a few nested ones expand to billions of nodes, the "billion laughs"),
    and so is nesting deeper than MAX_DEPTH (the compiled YAML composer recurses in C).
    """
    if os.path.exists(path) and not (os.path.isfile(path) or os.path.isdir(path)):  # a pipe would block the read
        raise _error(path, "cannot read the supervisor file: not a regular file (a pipe or device)")
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)  # read no further: the path may be a device or a pipe
    except OSError as exc:
        raise _error(path, f"cannot read the supervisor file: {exc.strerror or exc}") from None
    if len(data) > MAX_FILE_BYTES:
        raise _error(path, f"is larger than {MAX_FILE_BYTES} bytes; a Nadzoru 2 file is a few KB")
    if not data.strip():
        raise _error(path, "is empty; a Nadzoru 2 file is a YAML mapping")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _error(path, f"is not UTF-8 text (byte {data[exc.start]:#04x} at offset {exc.start})") from None
    try:
        problem = _structure_problem(yaml.parse(text, Loader=_Loader))
        if problem is None:
            return yaml.load(text, Loader=_Loader)
    except yaml.YAMLError as exc:
        raise _error(path, f"not valid YAML: {brief(exc)}") from None
    except ValueError as exc:  # a value YAML reads but Python refuses (an integer of too many digits)
        raise _error(path, f"not valid YAML: {brief(exc)}") from None
    raise _error(path, problem)


def _structure_problem(events):
    """Why a stream of YAML events must not be built (an alias, deep nesting), or None."""
    depth = 0
    for event in events:
        if isinstance(event, yaml.AliasEvent):
            mark = event.start_mark
            where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
            return f"uses a YAML alias{where}; aliases are not allowed (Nadzoru 2 writes none)"
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_DEPTH:
                return f"nests lists or mappings more than {MAX_DEPTH} deep; a Nadzoru 2 file nests 3"
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1
    return None


def _is_int(value):
    # YAML booleans are Python ints too; a flag written as `true` is not what Nadzoru writes.
    return isinstance(value, int) and not isinstance(value, bool)


def _sized_list(path, doc, key, size, size_key):
    value = doc[key]
    if not isinstance(value, list):
        raise _error(path, f"{key} should be a list of {size} entries ({size_key}), found {_show(value)}")
    if len(value) != size:
        raise _error(path, f"{key} has {len(value)} entries but {size_key} is {size}")
    return value


def _flags(path, values, where):
    for i, value in enumerate(values):
        if not _is_int(value) or value not in (0, 1):
            raise _error(path, f"{where}[{i}] should be 0 or 1, found {_show(value)}")
    return np.array(values, dtype=bool)


def _count(path, doc, key):
    value = doc[key]
    if not _is_int(value) or value < 1:
        raise _error(path, f"{key} should be a positive integer, found {_show(value)}")
    return value


def _state_indices(path, doc, key, n_supervisors):
    values = _sized_list(path, doc, key, n_supervisors, "num_supervisors")
    for k, value in enumerate(values):
        if not _is_int(value) or value < 0:
            raise _error(path, f"{key}[{k}] should be a state index (integer >= 0), found {_show(value)}")
    return values


def _block_ends(path, positions, data_length):
    """End offset (exclusive) of each supervisor's block in sup_data."""
    for k, pos in enumerate(positions):
        if not _is_int(pos):
            raise _error(path, f"sup_data_pos[{k}] should be an integer offset, found {_show(pos)}")
    if positions[0] != 0:
        raise _error(path, f"sup_data_pos[0] should be 0 (the first block starts sup_data), found {positions[0]}")
    for k in range(1, len(positions)):
        if positions[k] <= positions[k - 1]:
            raise _error(path, f"sup_data_pos should increase: sup_data_pos[{k}] = {positions[k]} "
                               f"after sup_data_pos[{k - 1}] = {positions[k - 1]}")
    if positions[-1] >= data_length:
        raise _error(path, f"sup_data_pos[{len(positions) - 1}] = {positions[-1]} is past the end of "
                           f"sup_data ({data_length} entries)")
    return list(positions[1:]) + [data_length]


def _walk_block(path, data, k, start, end, event_index, alphabet_k):
    """Parse supervisor k's states from ``data[start:end]``.

    Returns
    -------
    list of dict
        One dict per state, ``{event_index: (target, name, offset)}``; targets are
        checked against the number of states by the caller, once it is known.
    """
    boundary = "the next supervisor's block starts there" if end < len(data) else "the end of sup_data"
    states = []
    i = start
    while i < end:
        s = len(states)
        n_out = data[i]
        if not _is_int(n_out) or n_out < 0:
            raise _error(path, f"sup_data[{i}] (supervisor {k}, state {s}) should be n_out, the number of "
                               f"outgoing transitions (integer >= 0), found {_show(n_out)}")
        if i + 1 + 3 * n_out > end:
            raise _error(path, f"sup_data truncated or bad n_out: supervisor {k}, state {s} at sup_data[{i}] "
                               f"has n_out = {n_out}, which needs {3 * n_out} entries after it, but its block "
                               f"ends at sup_data[{end}] ({boundary})")
        out = {}
        for j in range(i + 1, i + 1 + 3 * n_out, 3):
            name, hi, lo = data[j:j + 3]
            if not isinstance(name, str) or name not in event_index:
                raise _error(path, f"sup_data[{j}] (supervisor {k}, state {s}): event {_show(name)} is not in events")
            e = event_index[name]
            if not alphabet_k[e]:
                raise _error(path, f"sup_data[{j}] (supervisor {k}, state {s}): event {_show(name)} is not in "
                                   f"supervisor {k}'s alphabet (sup_events[{k}])")
            if e in out:
                raise _error(path, f"sup_data[{j}] (supervisor {k}, state {s}): second transition on event "
                                   f"{_show(name)}; a supervisor is deterministic")
            if not (_is_int(hi) and _is_int(lo) and hi >= 0 and 0 <= lo < 256):
                raise _error(path, f"sup_data[{j + 1}:{j + 3}] (supervisor {k}, state {s}, event {_show(name)}) "
                                   f"should be target_hi >= 0 and 0 <= target_lo < 256, found {_show(hi)}, {_show(lo)}")
            out[e] = (hi * 256 + lo, name, j)
        states.append(out)
        i += 1 + 3 * n_out
    return states


def load_supervisor(path: str | os.PathLike) -> Automaton:
    """Read, validate and build the supervisors of a Nadzoru 2 YAML file.

    Everything is checked before the automaton is built; ``sup_current_state``
    is validated but the machine starts from ``sup_init_state``.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    Automaton

    Raises
    ------
    SupervisorFileError
        On a file that is missing, unreadable, larger than MAX_FILE_BYTES, empty,
        not UTF-8, not YAML or using YAML aliases; on a missing key, a list whose
        length disagrees with ``num_events`` / ``num_supervisors``, an unknown
        event in ``sup_data``, a dangling target, an out-of-range state, or a
        truncated ``sup_data``. The message is one line; it names the file, what
        is at fault and what was expected, and shows at most 60 characters of a
        value.
    """
    path = Path(path)
    doc = _read_yaml(path)
    if not isinstance(doc, dict):
        raise _error(path, f"should be a mapping with keys {', '.join(_REQUIRED_KEYS)}")
    missing = [key for key in _REQUIRED_KEYS if key not in doc]
    if missing:
        raise _error(path, f"missing top-level key(s) {', '.join(missing)}; "
                           f"a Nadzoru 2 file has {', '.join(_REQUIRED_KEYS)}")

    n_events = _count(path, doc, "num_events")
    n_supervisors = _count(path, doc, "num_supervisors")

    names = _sized_list(path, doc, "events", n_events, "num_events")
    for i, name in enumerate(names):
        if not isinstance(name, str) or not name.startswith(_PREFIX) or name == _PREFIX:
            raise _error(path, f"events[{i}] should be a name starting with {_PREFIX!r}, found {_show(name)}")
    event_index = {name: i for i, name in enumerate(names)}
    if len(event_index) != n_events:
        duplicated = sorted(name for name, count in Counter(names).items() if count > 1)
        raise _error(path, f"events repeats {', '.join(duplicated)}")

    controllable = _flags(path, _sized_list(path, doc, "ev_controllable", n_events, "num_events"),
                          "ev_controllable")
    shared = np.zeros(n_events, dtype=bool)
    # Older exports call the flags ev_public; either is accepted, ev_shared wins if both are present.
    for key in ("ev_public", "ev_shared"):
        if key in doc:
            shared = _flags(path, _sized_list(path, doc, key, n_events, "num_events"), key)

    rows = _sized_list(path, doc, "sup_events", n_supervisors, "num_supervisors")
    alphabet = np.zeros((n_supervisors, n_events), dtype=bool)
    for k, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != n_events:
            raise _error(path, f"sup_events[{k}] should be a list of {n_events} flags (num_events), found {_show(row)}")
        alphabet[k] = _flags(path, row, f"sup_events[{k}]")

    init_state = _state_indices(path, doc, "sup_init_state", n_supervisors)
    current_state = _state_indices(path, doc, "sup_current_state", n_supervisors)
    positions = _sized_list(path, doc, "sup_data_pos", n_supervisors, "num_supervisors")
    data = doc["sup_data"]
    if not isinstance(data, list):
        raise _error(path, f"sup_data should be a list, found {_show(data)}")

    # A block runs from its sup_data_pos to the next one (or the end): walking it
    # is the only way to learn how many states a supervisor has.
    ends = _block_ends(path, positions, len(data))
    blocks = [_walk_block(path, data, k, positions[k], ends[k], event_index, alphabet[k])
              for k in range(n_supervisors)]

    for k, states in enumerate(blocks):
        n = len(states)
        for s, out in enumerate(states):
            for target, name, j in out.values():
                if target >= n:
                    raise _error(path, f"dangling target at sup_data[{j}]: supervisor {k}, state {s}, event "
                                       f"{_show(name)} goes to state {target}, but supervisor {k} has {n} states "
                                       f"(0..{n - 1})")
        for key, values in (("sup_init_state", init_state), ("sup_current_state", current_state)):
            if values[k] >= n:
                raise _error(path, f"{key}[{k}] = {values[k]} is out of range: supervisor {k} has {n} states "
                                   f"(0..{n - 1})")

    init = np.array(init_state, dtype=np.int64)
    for array in (controllable, shared, alphabet, init):
        array.setflags(write=False)  # the dataclass is frozen; so are its arrays
    return Automaton(
        events=tuple(name[len(_PREFIX):] for name in names),
        controllable=controllable,
        shared=shared,
        alphabet=alphabet,
        init_state=init,
        transitions=tuple({(s, e): t[0] for s, out in enumerate(states) for e, t in out.items()}
                          for states in blocks),
        n_states=tuple(len(states) for states in blocks),
    )


# --------------------------------------------------------------------------- kernel


@borrowing
def take(table, states, uav, event):
    """Apply event ``event`` to UAV ``uav`` if every local supervisor allows it.

    Atomic: either all K local states move, or none does.

    Parameters
    ----------
    table : ndarray, shape (K, S, E), int64
        From :meth:`Automaton.transition_table`; -1 marks a forbidden transition.
    states : ndarray, shape (n_uavs, K), int64
        Local states of every UAV; row ``uav`` is updated in place.
    uav : int
        Row of ``states``.
    event : int
        Column of ``table``.

    Returns
    -------
    bool
        True if the event was applied, False if some supervisor forbids it.
    """
    n_supervisors = table.shape[0]
    for k in range(n_supervisors):
        if table[k, states[uav, k], event] < 0:
            return False
    for k in range(n_supervisors):
        states[uav, k] = table[k, states[uav, k], event]
    return True


# --------------------------------------------------------------------------- virtual machine


class SupervisorVM:
    """Generic virtual machine for any Nadzoru 2 file (the published controllers' step).

    Parameters
    ----------
    automaton : Automaton
        The supervisors; the machine starts in ``automaton.init_state``.
    rng : numpy.random.Generator, optional
        Chooses among enabled controllable events; a fresh unseeded generator if None.

    Notes
    -----
    Every event goes through :meth:`trigger`, which is atomic and raises
    :class:`SupervisorError` when a supervisor holding the event has no
    transition on it. Of the six published files, only
    multi-human-swarm-worker omits uncontrollable events in some states (for
    instance ``notNearC`` while already not near). The published C++ machine
    then silently leaves that supervisor in place while the others move; here
    such an event is refused (SupervisorError), so an input check must fire only
    when the event can happen. The packaged UAV controller lists every
    uncontrollable event in every state, so it is not affected.
    """

    def __init__(self, automaton: Automaton, rng: np.random.Generator | None = None) -> None:
        self.automaton = automaton
        self.rng = np.random.default_rng() if rng is None else rng
        self._table = automaton.transition_table(automaton.events)
        self._states = automaton.init_state.astype(np.int64).reshape(1, -1)
        self._checks = {}     # event index -> input check (uncontrollable events only)
        self._callbacks = {}  # event index -> callback

    @property
    def state(self) -> tuple[int, ...]:
        """Current local state of each of the K supervisors."""
        return tuple(int(s) for s in self._states[0])

    def on_input(self, event: str, check: Callable[[], bool]) -> None:
        """Register the input check of uncontrollable event ``event`` (replaces any earlier one).

        Raises
        ------
        ValueError
            If ``event`` is controllable (SupervisorFileError, a ValueError, if unknown).
        """
        e = self.automaton.event_index(event)
        if self.automaton.controllable[e]:
            raise ValueError(f"event {event!r} is controllable; input checks are for uncontrollable events")
        self._checks[e] = check

    def on_event(self, event: str, callback: Callable[[], None]) -> None:
        """Register the callback run whenever ``event`` is applied (replaces any earlier one)."""
        self._callbacks[self.automaton.event_index(event)] = callback

    def _enabled_indices(self) -> list[int]:
        rows = self._table[np.arange(self.automaton.n_supervisors), self._states[0]]  # (K, N)
        allowed = (rows >= 0).all(axis=0) & self.automaton.controllable
        return np.flatnonzero(allowed).tolist()

    def enabled(self) -> list[str]:
        """Controllable events enabled now, in event-index order."""
        return [self.automaton.events[e] for e in self._enabled_indices()]

    def _apply(self, e: int) -> None:
        if not take(self._table, self._states, 0, e):
            name = self.automaton.events[e]
            blocking = [f"supervisor {k} in state {s}" for k, s in enumerate(self.state)
                        if self._table[k, s, e] < 0]
            raise SupervisorError(f"event {name!r} is not allowed now: no transition on it for "
                                  f"{', '.join(blocking)}")
        callback = self._callbacks.get(e)
        if callback is not None:
            callback()

    def trigger(self, event: str) -> None:
        """Apply ``event`` (controllable or not) now and run its callback.

        Raises
        ------
        SupervisorError
            If a supervisor whose alphabet holds the event has no transition on
            it from its current state; then no state moves and no callback runs.
        """
        self._apply(self.automaton.event_index(event))

    def step(self) -> str | None:
        """One step of the published machine.

        1. Every input check is evaluated, then each uncontrollable event whose
           check fired is applied, in event-index order.
        2. One enabled controllable event is chosen uniformly at random with
           ``self.rng`` and applied.

        Returns
        -------
        str or None
            The controllable event applied, or None if none was enabled.

        Raises
        ------
        SupervisorError
            If a fired uncontrollable event is not allowed (the events applied
            before it in this step stay applied).
        """
        # All checks are read before any event moves, as the published machine buffers its inputs.
        fired = [e for e, check in sorted(self._checks.items()) if check()]
        for e in fired:
            self._apply(e)
        candidates = self._enabled_indices()
        if not candidates:
            return None
        e = candidates[self.rng.integers(len(candidates))]
        self._apply(e)
        return self.automaton.events[e]
