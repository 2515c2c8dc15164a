"""Execute a study's independent runs: in this process, in a local process
pool (concurrent.futures), or on a Dask cluster. The only module that imports
concurrent.futures' process pool or dask.

Why these libraries: :class:`concurrent.futures.ProcessPoolExecutor` ships
with Python and is all one machine needs; Dask's futures API is the same
shape (``submit``, ``as_completed``) and scales the very same worker function
to a cluster, so a user who outgrows one machine passes ``--scheduler
tcp://host:8786`` and nothing else changes. Dask is optional (the ``cluster``
extra) and imported only when a scheduler address is given.

Processes are started with ``spawn``: a forked child of a process that runs
BLAS threads (numpy/scipy) or a test runner can deadlock, and spawn behaves
the same on every platform.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
from collections.abc import Callable, Sequence

from .runs import ModelSource, RunData, RunSpec, execute_run, time_run

__all__ = ["run_specs", "run_tasks", "default_jobs"]


def default_jobs() -> int:
    """Cores this process may use (``os.sched_getaffinity`` where available)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:        # macOS, Windows
        return max(1, os.cpu_count() or 1)


def run_specs(source: ModelSource, specs: Sequence[RunSpec], jobs: int | None = None,
              scheduler: str | None = None,
              on_done: Callable[[RunData], None] | None = None) -> list[RunData]:
    """Run every spec; results in the order of ``specs``.

    Parameters
    ----------
    source : ModelSource
    specs : sequence of RunSpec
    jobs : int, optional
        Worker processes on this machine for the runs that are not timed
        (``RunSpec.repeat`` 0); 1 runs them in this process (no pool);
        default: the number of cores. The timed runs go one at a time in
        this process, after the others. Ignored with ``scheduler``.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); the runs are
        submitted to its workers, which need mbdsl installed.
    on_done : callable, optional
        Called with each RunData as it arrives (progress bars).

    Returns
    -------
    list of RunData

    Raises
    ------
    MbdError
        A worker could not load the model.
    ImportError
        ``scheduler`` given without dask.distributed installed (the message
        names the extra to install).
    OSError
        The scheduler cannot be reached.
    """
    specs = list(specs)
    on_done = on_done or (lambda data: None)
    if scheduler:
        return run_tasks(execute_run, [(source, spec) for spec in specs],
                         scheduler=scheduler, on_done=on_done)
    results: list = [None] * len(specs)
    timed = [i for i, spec in enumerate(specs) if spec.repeat]
    untimed = [i for i, spec in enumerate(specs) if not spec.repeat]
    # longest runs first: a pool's tail is then short runs, not one long one
    untimed.sort(key=lambda i: -specs[i].t_end / specs[i].h)
    for i, data in zip(untimed, run_tasks(execute_run, [(source, specs[i]) for i in untimed],
                                          jobs=jobs, on_done=on_done)):
        results[i] = data
    _timed(source, specs, timed, results, on_done)
    return results


def run_tasks(fn: Callable, tasks: Sequence[tuple], jobs: int | None = None,
              scheduler: str | None = None, on_done: Callable | None = None) -> list:
    """fn(*task) for every task, independent of each other; results in the
    order of ``tasks``.

    Parameters
    ----------
    fn : callable
        A module-level function (workers import it by name).
    tasks : sequence of tuple
        Its arguments per task (picklable: sent to other processes).
    jobs : int, optional
        Local worker processes (``spawn``); 1 runs the tasks in this process;
        default: the number of cores. Ignored with ``scheduler``.
    scheduler : str, optional
        A Dask scheduler's address (``tcp://host:8786``); the tasks go to its
        workers, which need mbdsl installed.
    on_done : callable, optional
        Called with each result as it arrives, in this process.

    Raises
    ------
    ImportError
        ``scheduler`` given without dask.distributed installed (the message
        names the extra to install).
    OSError
        The scheduler cannot be reached.
    """
    tasks = list(tasks)
    on_done = on_done or (lambda result: None)
    results: list = [None] * len(tasks)
    if scheduler:
        _run_dask(fn, tasks, scheduler, results, on_done)
        return results
    jobs = default_jobs() if jobs is None else max(1, int(jobs))
    if jobs > 1 and len(tasks) > 1:
        _pool(fn, tasks, jobs, results, on_done)
    else:
        for i, task in enumerate(tasks):
            results[i] = fn(*task)
            on_done(results[i])
    return results


def _timed(source, specs, which, results, on_done):
    """The timed specs of indices ``which``, in this process, one at a time,
    after any pool has ended: two runs timed at once on shared cores disturb
    each other's time. Each runs once for its results (the warm-up), then
    their repeats go round-robin, one of each in turn, so that a machine
    that slows down for a while slows every method alike rather than the
    one it happened to be timing. Measured (``mbdsl study cost
    models/slider_crank.mbd``, 2 cores, median of 3): HHT-SI2 / HHT-I3
    came out 1.02, 0.73 and 1.44 in three studies, HHT-ADD / HHT-I3 2.13,
    0.86 and 1.75, with two workers each timing its own runs; 1.41, 1.47
    and 1.28, and 1.65, 1.73 and 1.67, timed here."""
    for i in which:
        results[i] = execute_run(source, dataclasses.replace(specs[i], repeat=0))
        results[i].spec = specs[i]
        on_done(results[i])
    done = [i for i in which if results[i].completed]
    times = {i: [] for i in done}
    for r in range(max((specs[i].repeat for i in done), default=0)):
        for i in done:
            if r < specs[i].repeat:
                times[i].append(time_run(source, specs[i]))
    for i in done:
        results[i].wall_times = times[i]


def _pool(fn, tasks, jobs, results, on_done):
    """The tasks in a local process pool of ``jobs`` workers, submitted in
    order, their results into ``results``."""
    from concurrent.futures import ProcessPoolExecutor, as_completed
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(jobs, len(tasks)), mp_context=ctx) as pool:
        futures = {pool.submit(fn, *task): i for i, task in enumerate(tasks)}
        try:
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                on_done(results[futures[fut]])
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise


def _run_dask(fn, tasks, scheduler, results, on_done):
    """The tasks on a Dask cluster (``dask.distributed``), their results into
    ``results``."""
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:
        raise ImportError("--scheduler needs dask.distributed: pip install 'mbdsl[cluster]'") from exc
    with Client(scheduler, timeout=30) as client:
        futures = [client.submit(fn, *task, pure=False) for task in tasks]
        index = {fut.key: i for i, fut in enumerate(futures)}
        try:
            for fut in as_completed(futures):
                results[index[fut.key]] = fut.result()
                on_done(results[index[fut.key]])
        except BaseException:
            client.cancel(futures)
            raise
