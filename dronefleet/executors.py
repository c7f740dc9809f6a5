"""Where a sweep's runs execute: processes of this machine, or a Dask cluster.

Each executor maps ``function`` over ``items`` and yields ``(item, result, error)`` in the
order they finish: ``error`` is None, or the exception the executor raised for that item
instead of a result (its worker process died, say), and then ``result`` is None. A
failure of one item never stops the others. ``function`` and the items must pickle (a
module-level function or a ``functools.partial`` of one): they travel to other processes.
"""

import multiprocessing
from collections import deque
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from .sweep import SweepError


def _outcome(future):
    """``(result, None)`` of a finished future, or ``(None, error)`` if getting its result raises.

    ``function`` returns its failures rather than raise them (see ``sweep.execute``), so an
    exception here comes from the executor: a dead worker, a lost or cancelled task.
    """
    try:
        return future.result(), None
    except Exception as error:
        return None, error


def local(function, items, jobs):
    """``function`` over ``items`` on ``jobs`` processes of this machine.

    The first item runs in this process before any worker starts: it compiles the engine
    into numba's disk cache (or loads it from there), so that the workers load it rather
    than each compiling it at the same time (~20 s of CPU each). With ``jobs == 1`` every
    item runs in this process, which a crash then stops. Workers are spawned, not forked:
    a fork of a process with threads (numba, pyarrow) can deadlock.

    Each worker is a pool of its own that holds one item at a time. A process pool whose
    worker dies (killed, out of memory, segfault) fails every item it holds with
    ``BrokenProcessPool``; holding one, it names the item that killed it exactly, and only
    that worker is replaced, so the other items run on unaffected.
    """
    items = deque(items)
    if not items:
        return
    first = items.popleft()
    yield first, function(first), None
    if jobs == 1:
        for item in items:
            yield item, function(item), None
        return
    context = multiprocessing.get_context("spawn")
    holding = {}  # future -> (its pool, its item)

    def submit(pool):
        item = items.popleft()
        holding[pool.submit(function, item)] = pool, item

    try:
        for _ in range(min(jobs, len(items))):
            submit(ProcessPoolExecutor(1, mp_context=context))
        while holding:
            finished, _ = wait(holding, return_when=FIRST_COMPLETED)
            for future in finished:
                pool, item = holding.pop(future)
                result, error = _outcome(future)
                if isinstance(error, BrokenProcessPool):  # its worker died: a new one takes its place
                    pool.shutdown()
                    pool = ProcessPoolExecutor(1, mp_context=context)  # starts no process until a submit
                if items:
                    submit(pool)  # before the yield: the worker does not wait for the caller
                else:
                    pool.shutdown()
                yield item, result, error
    finally:
        for pool, _ in holding.values():  # on Ctrl-C: wait for the items running; the others never start
            pool.shutdown()


def dask(function, items, scheduler, keys):
    """``function`` over ``items`` on the Dask cluster at ``scheduler``, one task per item.

    ``keys`` names the tasks (one per item, as shown on the Dask dashboard). Dask
    distributed is an optional dependency: ``pip install 'dronefleet[dask]'``. A task
    whose workers keep dying is given up by the scheduler (``KilledWorker``, after
    ``distributed.scheduler.allowed-failures`` deaths), and is then that item's error.
    """
    try:
        from distributed import Client, as_completed as dask_completed
    except ImportError:
        raise SweepError("--executor dask needs Dask distributed: pip install 'dronefleet[dask]'") from None
    keys, items = list(keys), list(items)
    item_of = dict(zip(keys, items))
    try:
        client = Client(scheduler)
    except OSError as error:
        raise SweepError(f"cannot reach the Dask scheduler at {scheduler}: {error}") from None
    with client:
        # No reference to a future outlives its turn here: Dask then forgets the finished
        # tasks, rather than run them again should the worker that holds their result die.
        for future in dask_completed(client.map(function, items, key=keys)):
            yield item_of[future.key], *_outcome(future)
