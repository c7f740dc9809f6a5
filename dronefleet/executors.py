"""Where a sweep's runs execute: processes of this machine, or a Dask cluster.

Each executor maps ``function`` over ``items`` and yields ``(item, result)`` pairs in the
order they finish. ``function`` and the items must pickle (a module-level function or a
``functools.partial`` of one): they travel to other processes.
"""

import multiprocessing
from concurrent.futures import ProcessPoolExecutor, as_completed

from .sweep import SweepError


def local(function, items, jobs):
    """``function`` over ``items`` on ``jobs`` processes of this machine.

    The first item runs in this process before any worker starts: it compiles the engine
    into numba's disk cache (or loads it from there), so that the workers load it rather
    than each compiling it at the same time (~20 s of CPU each). Workers are spawned, not
    forked: a fork of a process with threads (numba, pyarrow) can deadlock.
    """
    items = list(items)
    if not items:
        return
    yield items[0], function(items[0])
    rest = items[1:]
    if jobs == 1 or not rest:
        for item in rest:
            yield item, function(item)
        return
    pool = ProcessPoolExecutor(min(jobs, len(rest)), mp_context=multiprocessing.get_context("spawn"))
    try:
        futures = {pool.submit(function, item): item for item in rest}
        for future in as_completed(futures):
            yield futures[future], future.result()
    finally:
        pool.shutdown(cancel_futures=True)  # on Ctrl-C, drop the queued items rather than run them


def dask(function, items, scheduler, keys):
    """``function`` over ``items`` on the Dask cluster at ``scheduler``, one task per item.

    ``keys`` names the tasks (one per item, as shown on the Dask dashboard). Dask
    distributed is an optional dependency: ``pip install 'dronefleet[dask]'``.
    """
    try:
        from distributed import Client, as_completed as dask_completed
    except ImportError:
        raise SweepError("--executor dask needs Dask distributed: pip install 'dronefleet[dask]'") from None
    items = list(items)
    try:
        client = Client(scheduler)
    except OSError as error:
        raise SweepError(f"cannot reach the Dask scheduler at {scheduler}: {error}") from None
    with client:
        futures = client.map(function, items, key=list(keys))
        item_of = {future.key: item for future, item in zip(futures, items)}
        for future in dask_completed(futures):
            yield item_of[future.key], future.result()
