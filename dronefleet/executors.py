"""Where a sweep's runs execute: processes of this machine, or a Dask cluster.

Each executor maps ``function`` over ``items`` and yields ``(item, result, error)`` in the
order they finish: ``error`` is None, or the exception the executor raised for that item
instead of a result (its worker process died, say), and then ``result`` is None. A
failure of one item never stops the others. ``function`` and the items must pickle (a
module-level function or a ``functools.partial`` of one): they travel to other processes.
"""

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, wait
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

from . import interrupt
from .config import SweepError

#: ``prctl`` option: the signal the kernel sends this process when its parent dies (linux/prctl.h).
_PR_SET_PDEATHSIG = 1
#: How often a worker without ``prctl`` looks whether its parent is still there (s).
_PARENT_POLL_S = 1.0

#: How long `dask` waits for the scheduler to answer before giving up (s).
SCHEDULER_TIMEOUT_S = 10.0

#: Idle workers of :func:`local` kept for its next call, within :func:`reused_workers`; None outside.
_kept: list | None = None

Item = TypeVar("Item")
Result = TypeVar("Result")
#: What an executor yields per item: ``(item, result, None)`` or ``(item, None, error)``.
Outcomes = Iterator[tuple[Item, Result | None, BaseException | None]]


def _outcome(future):
    """``(result, None)`` of a finished future, or ``(None, error)`` if getting its result raises.

    ``function`` returns its failures rather than raise them (see ``sweep.execute``), so an
    exception here comes from the executor: a dead worker, a lost or cancelled task.
    """
    try:
        return future.result(), None
    except Exception as error:
        return None, error


#: The signals that stop a sweep: Ctrl-C, and SIGTERM (a scheduler ending a job, ``scancel``).
STOPPING = {signal.SIGINT, signal.SIGTERM}
#: Whether this platform has signal masks (POSIX; not Windows, where a worker starts without them).
MASKS = hasattr(signal, "pthread_sigmask")


def _block_stopping(block: bool) -> None:
    """Block (or unblock) :data:`STOPPING` in this thread, where the platform has signal masks; elsewhere
    nothing: a Ctrl-C while a worker starts may then print that worker's traceback, nothing worse."""
    if MASKS:
        signal.pthread_sigmask(signal.SIG_BLOCK if block else signal.SIG_UNBLOCK, STOPPING)


def _start_worker(parent):
    """Worker initializer: Ctrl-C and SIGTERM as :func:`_interruptible` says, and the end of the
    worker with its parent."""
    # Started with them blocked (see local): ignored from now on, one pending is dropped.
    for stopping in STOPPING:
        signal.signal(stopping, signal.SIG_IGN)
    _block_stopping(False)
    _die_with_parent(parent)


def _interruptible(function, item):
    """``function(item)`` in a worker, Ctrl-C or SIGTERM raising KeyboardInterrupt meanwhile only.

    The terminal sends Ctrl-C to the workers too, and SLURM its SIGTERM to every process of
    a job. An idle worker ignores them (it would print a traceback of its own, or die); a
    worker's item stops (its compiled kernel at its next check point, see
    :mod:`dronefleet.interrupt`) and returns the KeyboardInterrupt to the parent.
    """
    for stopping in STOPPING:
        signal.signal(stopping, _stop_once)
    try:
        return function(item)
    finally:
        for stopping in STOPPING:
            signal.signal(stopping, interrupt.ignore)


def _stop_once(signum, frame):
    """The first stopping signal of an item raises KeyboardInterrupt; the next are ignored (the
    terminal's Ctrl-C, then the parent's, would strike inside the handling of the first)."""
    for stopping in STOPPING:
        signal.signal(stopping, interrupt.ignore)
    raise KeyboardInterrupt


def _die_with_parent(parent):
    """End this worker when the process ``parent`` (its pid) that started it dies.

    A worker would otherwise outlive a sweep killed with SIGKILL (which no handler sees) and
    go on running its run; the resource trackers (multiprocessing's and loky's), which the
    workers keep alive by holding their pipes, then live on too. Linux: the kernel sends SIGKILL at the
    parent's death (``prctl(PR_SET_PDEATHSIG)``); elsewhere a daemon thread polls the parent
    pid. A run killed in the middle leaves at most a hidden temporary file, as any kill does.
    """
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0:
            if os.getppid() != parent:  # died before the prctl: no signal will come
                os._exit(1)
            return
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True, name="watch-parent").start()


def _watch_parent(parent):
    while os.getppid() == parent:  # once the parent dies, the worker is adopted: its ppid changes
        time.sleep(_PARENT_POLL_S)
    os._exit(1)


@contextlib.contextmanager
def reused_workers() -> Iterator[None]:
    """Within the block, the worker processes of :func:`local` outlive its call: a later call's
    items go to the workers an earlier one left idle, which have their modules imported and
    their compiled kernels loaded already (a second of CPU per worker, once per command rather
    than once per sweep). The kept workers end at the block's end; nested, the outer block's
    end ends them."""
    global _kept
    if _kept is not None:
        yield
        return
    _kept = []
    try:
        yield
    finally:
        pools, _kept = _kept, None
        for pool in pools:
            _end(pool)


def _worker_pool():
    """A pool of one worker process: a kept idle one (see :func:`reused_workers`) or a new one,
    which starts no process until its first submit."""
    if _kept:
        return _kept.pop()
    from loky import ProcessPoolExecutor  # imported with a worker process only
    from loky.backend import get_context

    # "loky", not "loky_init_main", which runs the main module as spawn does
    return ProcessPoolExecutor(1, context=get_context("loky"), initializer=_start_worker, initargs=(os.getpid(),))


def _release(pool):
    if _kept is None:
        _end(pool)
    else:
        _kept.append(pool)


def _end(pool):
    """Shut ``pool`` down, its worker killed: it holds no item (done, or stopped) and its end must
    not wait on it: a thread a plugin started at import would keep it, and this process, alive."""
    pool.shutdown(kill_workers=True)


def _submit(pool, function, item):
    """``function(item)`` on ``pool``'s worker (see :func:`_interruptible`): its future."""
    from multiprocessing import resource_tracker

    # A worker starts in the submit: with SIGINT blocked, which it inherits, so that a Ctrl-C
    # while it starts up is no traceback of its own (as multiprocessing's resource tracker
    # does); it is delivered here once unblocked. The worker's start starts that tracker if it
    # is not running, which unblocks both signals as it ends: so it is started first.
    resource_tracker.ensure_running()
    _block_stopping(True)
    try:
        return pool.submit(_interruptible, function, item)
    finally:
        _block_stopping(False)


def _workers(pool):
    return list((pool._processes or {}).values())  # the pool's worker (a private attribute)


def local(function: Callable[[Item], Result], items: Iterable[Item], jobs: int) -> Outcomes[Item, Result]:
    """``function`` over ``items`` on ``jobs`` processes of this machine.

    With ``jobs == 1`` every item runs in this process, which a crash (or a kill, as by the
    out-of-memory killer) of one item then stops. Otherwise every item runs in a worker, the
    first one alone before the others start: it compiles the engine into numba's disk cache (or
    loads it from there), so that the other workers load it rather than each compiling it at the
    same time (~20 s of CPU each). Workers are new interpreters, not
    forks (a fork of a process with threads, numba's or pyarrow's, can deadlock), started by
    loky rather than multiprocessing's ``spawn``: they import ``function``'s module but never
    the caller's main module, which ``spawn`` runs again in every worker (an unguarded
    script would run its own work again in each, ``python - < script.py`` fails).

    Each worker is a pool of its own that holds one item at a time. A process pool whose
    worker dies (killed, out of memory, segfault) fails every item it holds with
    ``BrokenProcessPool``; holding one, it names the item that killed it exactly, and only
    that worker is replaced, so the other items run on unaffected. Workers end with the call, or
    within :func:`reused_workers` are kept for the next, and end when this process dies, even by
    SIGKILL (see :func:`_die_with_parent`).

    Ctrl-C (KeyboardInterrupt here) is passed on to the workers (the terminal sends it to them
    too, but ``kill -INT`` does not), whose items stop: the items done are kept, the running
    ones end without writing more (see :func:`_interruptible`), the others never start.
    """
    items = deque(items)
    if jobs == 1:
        for item in items:
            yield item, function(item), None
        return
    holding = {}  # future -> (its pool, its item)

    def submit(pool):
        item = items.popleft()
        holding[_submit(pool, function, item)] = pool, item

    try:
        if items:
            submit(_worker_pool())  # the first alone: the others start once it has compiled the kernels
        while holding:
            finished, _ = wait(holding, return_when=FIRST_COMPLETED)
            for future in finished:
                pool, item = holding.pop(future)
                result, error = _outcome(future)
                if isinstance(error, BrokenProcessPool):  # its worker died: a new one takes its place
                    pool.shutdown()
                    pool = _worker_pool()  # starts no process until a submit
                if items:
                    submit(pool)  # before the yield: the worker does not wait for the caller
                else:
                    _release(pool)
                while items and len(holding) < jobs:
                    submit(_worker_pool())
                yield item, result, error
    finally:
        for pool, _ in holding.values():  # on Ctrl-C: stop the items running; the others never start
            for process in _workers(pool):
                with contextlib.suppress(ProcessLookupError):
                    os.kill(process.pid, signal.SIGINT)
        wait(holding, timeout=interrupt.GRACE_S)  # each stops at its next check point, writing nothing more
        for pool, _ in holding.values():
            _end(pool)


class WorkerDied(RuntimeError):
    """The worker process of :func:`contained` ended without returning: ``how`` says how
    (``exit code 0``, ``killed by SIGKILL``)."""

    def __init__(self, how: str) -> None:
        super().__init__(how)
        self.how = how


def contained(function: Callable[[Item], Result], item: Item) -> Result:
    """``function(item)`` in a worker process of its own, as :func:`local` runs an item: its result,
    or what it raised, raised here; :class:`WorkerDied` if the worker ends without either (the
    item called ``os._exit``, was killed, crashed). Ctrl-C and SIGTERM here end the worker at once
    (SIGKILL: the item only computes, this process writes what it returns) and are raised."""
    pool = _worker_pool()
    future = _submit(pool, function, item)
    workers = _workers(pool)
    try:
        result = future.result()
    except BrokenProcessPool:
        for process in workers:
            process.join()
        codes = [process.exitcode for process in workers if process.exitcode is not None]
        pool.shutdown()
        code = codes[0] if codes else None
        signals = {int(signum): signum.name for signum in signal.Signals}
        raise WorkerDied("no exit code" if code is None else f"exit code {code}" if code >= 0
                         else f"killed by {signals.get(-code, f'signal {-code}')}") from None
    except BaseException:
        if future.done():  # the item raised: its worker is as good as new
            _release(pool)
        else:  # Ctrl-C or SIGTERM here while the item runs: a plugin that ignores them must not hold us
            for process in workers:
                with contextlib.suppress(ProcessLookupError):
                    # SIGKILL; where there is none (Windows) os.kill's SIGTERM is TerminateProcess
                    os.kill(process.pid, getattr(signal, "SIGKILL", signal.SIGTERM))
            pool.shutdown(wait=False)
        raise
    _release(pool)
    return result


def dask(function: Callable[[Item], Result], items: Iterable[Item], scheduler: str,
         keys: Iterable[str]) -> Outcomes[Item, Result]:
    """``function`` over ``items`` on the Dask cluster at ``scheduler``, one task per item.

    Connects at once (within :data:`SCHEDULER_TIMEOUT_S`), so that a scheduler that cannot
    be reached is a SweepError before anything runs, then returns the generator of outcomes.
    ``keys`` names the tasks (one per item, as shown on the Dask dashboard). Dask
    distributed is an optional dependency: ``pip install 'dronefleet[dask]'``. A task
    whose workers keep dying is given up by the scheduler (``KilledWorker``, after
    ``distributed.scheduler.allowed-failures`` deaths), and is then that item's error.
    """
    try:
        from distributed import Client
    except ImportError:
        raise SweepError("--executor dask needs Dask distributed: pip install 'dronefleet[dask]'") from None
    try:
        client = Client(scheduler, timeout=SCHEDULER_TIMEOUT_S)
    except (OSError, ValueError) as error:  # refused, timed out (TimeoutError is an OSError), unresolvable
        reason = " ".join(str(error).split()) or type(error).__name__  # one line
        raise SweepError(f"cannot reach the Dask scheduler at {scheduler} within {SCHEDULER_TIMEOUT_S:g} s: "
                         f"{reason}") from None
    return _dask_outcomes(client, function, list(items), list(keys))


def _dask_outcomes(client, function, items, keys):
    from distributed import as_completed as dask_completed

    item_of = dict(zip(keys, items))
    with client:
        # No reference to a future outlives its turn here: Dask then forgets the finished
        # tasks, rather than run them again should the worker that holds their result die.
        for future in dask_completed(client.map(function, items, key=keys)):
            yield item_of[future.key], *_outcome(future)
