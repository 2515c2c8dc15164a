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

import multiprocessing
import os
from collections.abc import Callable, Sequence

from .runs import ModelSource, RunData, RunSpec, execute_run

__all__ = ["run_specs", "default_jobs"]


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
        Worker processes on this machine; 1 runs in this process (no pool);
        default: the number of cores. Ignored with ``scheduler``.
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
        return _run_dask(source, specs, scheduler, on_done)
    jobs = default_jobs() if jobs is None else max(1, int(jobs))
    if jobs == 1 or len(specs) <= 1:
        out = []
        for spec in specs:
            out.append(execute_run(source, spec))
            on_done(out[-1])
        return out
    from concurrent.futures import ProcessPoolExecutor, as_completed
    ctx = multiprocessing.get_context("spawn")
    results: list = [None] * len(specs)
    # longest runs first: the pool's tail is then short runs, not one long one
    order = sorted(range(len(specs)), key=lambda i: -specs[i].t_end / specs[i].h * specs[i].repeat)
    with ProcessPoolExecutor(max_workers=min(jobs, len(specs)), mp_context=ctx) as pool:
        futures = {pool.submit(execute_run, source, specs[i]): i for i in order}
        try:
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                on_done(results[futures[fut]])
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
    return results


def _run_dask(source, specs, scheduler, on_done):
    """The runs on a Dask cluster (``dask.distributed``)."""
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:
        raise ImportError("--scheduler needs dask.distributed: pip install 'mbdsl[cluster]'") from exc
    results: list = [None] * len(specs)
    with Client(scheduler, timeout=30) as client:
        futures = [client.submit(execute_run, source, spec, pure=False) for spec in specs]
        index = {fut.key: i for i, fut in enumerate(futures)}
        for fut in as_completed(futures):
            results[index[fut.key]] = fut.result()
            on_done(results[index[fut.key]])
    return results
