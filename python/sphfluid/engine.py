"""Where many runs run: one after another in this process, on a local Dask
cluster of worker processes, or on an existing Dask scheduler.

``sphfluid sweep``, ``dataset``, ``stress`` and ``validate`` hand their runs
to ``execute`` as tasks (a module-level function and one argument each, so a
worker process can import the one and unpickle the other); ``execute`` gives
each result to a callback as it comes, and the caller files it by the task's
place, so a report built from the results does not depend on the order they
came in. A task that raises on a worker (a worker that died, say) comes back
through the caller's ``failed``, never as the end of the other runs.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

from .scene import SceneError

NO_DASK = ('Dask distributed is not installed: pip install "sphfluid[sweep]" '
           "(or run one run after another in this process with --workers 0)")


class EngineError(SceneError):
    """The runs cannot start where they were asked to (no Dask, say)."""


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def local_workers(workers: int | None, threads: int) -> int:
    """Worker processes of a local cluster: as asked, or the cores / threads per run
    (so that workers x threads never exceeds the cores)."""
    return workers if workers is not None else max(1, cores() // max(threads, 1))


def threads_per_run(threads: int | None, workers: int | None, scheduler: str | None) -> int | None:
    """The OpenMP threads of each run: as given, else all cores in this process
    (None) and 1 on Dask (the runs share the cores)."""
    return threads if threads or in_process(workers, scheduler) else 1


def in_process(workers: int | None, scheduler: str | None) -> bool:
    """Whether the runs run one after another in this process (--workers 0)."""
    return workers == 0 and scheduler is None


def where(workers: int | None, threads: int, scheduler: str | None) -> str:
    """Where the runs run, said for a log line."""
    if scheduler is not None:
        return f"on the scheduler at {scheduler}"
    if in_process(workers, scheduler):
        return "one after another in this process"
    return f"on {local_workers(workers, threads)} local worker process(es)"


def options(workers: int | None, threads: int | None, scheduler: str | None) -> str:
    """The command-line options that say where the runs ran ("" for the default,
    one after another in this process), for a report's command line."""
    given = [("--workers", workers if workers != 0 else None), ("--threads", threads),
             ("--scheduler", scheduler)]
    return "".join(f" {flag} {value}" for flag, value in given if value is not None)


def check(workers: int | None, scheduler: str | None) -> None:
    """Raises EngineError now, before any run, when the runs need Dask and it is
    not installed."""
    if in_process(workers, scheduler):
        return
    try:
        import dask.distributed  # noqa: F401
    except ImportError:
        raise EngineError([NO_DASK]) from None


def execute(fn: Callable[[Any], Any], tasks: Sequence[Any],
            done: Callable[[int, Any], None], *, workers: int | None = 0, threads: int = 1,
            scheduler: str | None = None,
            failed: Callable[[int, BaseException], Any] | None = None,
            name: Callable[[int], str] | None = None,
            slots: list[int] | None = None) -> None:
    """fn(task) for every task, each result to done(place, result) as it comes.

    workers=0 (and no scheduler): one after another in this process, in order,
    and an exception of fn ends the loop as it would a plain loop. Otherwise on
    Dask: a LocalCluster of `workers` processes (default: the cores / threads),
    one task at a time each, or the scheduler at `scheduler`; a task that raises
    gives done(place, failed(place, exception)) (re-raised when failed is None).
    name(place) names a task on the cluster's dashboard; slots[0] is set to the
    tasks the engine runs at a time."""
    if slots is not None:
        slots[0] = 1
    if in_process(workers, scheduler):
        for place, task in enumerate(tasks):
            done(place, fn(task))
        return
    if not tasks:
        return
    check(workers, scheduler)
    import contextlib
    import logging

    from dask.distributed import Client, LocalCluster, as_completed

    with contextlib.ExitStack() as stack:
        if scheduler is not None:
            client = stack.enter_context(Client(scheduler, timeout="30s"))
        else:
            cluster = stack.enter_context(LocalCluster(
                n_workers=min(local_workers(workers, threads), len(tasks)),
                threads_per_worker=1, processes=True, dashboard_address=":0",
                silence_logs=logging.ERROR))
            client = stack.enter_context(Client(cluster))
        if slots is not None:
            info = client.scheduler_info().get("workers", {})
            slots[0] = max(1, sum(w.get("nthreads", 1) for w in info.values()))
        futures = {}
        for place, task in enumerate(tasks):
            key = f"sphfluid-{name(place) if name else 'task'}-{place}"
            futures[client.submit(fn, task, key=key, pure=False)] = place
        for future in as_completed(futures):
            place = futures[future]
            try:
                result = future.result()
            except Exception as e:  # noqa: BLE001 (one task's failure, not the others')
                if failed is None:
                    raise
                result = failed(place, e)
            done(place, result)
