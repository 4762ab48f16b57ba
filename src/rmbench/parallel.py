"""Independent cases on a pool of workers: in this process, local worker processes, or an
existing dask cluster.

Blind checks and benches run many cases that share nothing (a case draws its own robot from
``(seed, index)``); :func:`map_cases` runs them where asked and hands each back as it finishes, so
that its caller writes it down at once (a killed run resumes from what was written). Every worker
runs one thread per pool (:func:`rmbench.threads.worker_init`), so a case's result does not depend
on where it ran or beside how many others (bit for bit the result of a single-threaded run here).

Every local pool of worker processes in rmbench is made by :func:`worker_pool`: the cases of
:func:`map_cases`, and the long-lived pools of a calibration's problem and a gap diagnosis's
refiner, which keep their workers between maps.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

from rmbench.errors import InputError
from rmbench.threads import default_workers, worker_init

__all__ = ["map_cases", "worker_pool"]

_SINGLE_THREADED = False    # worker_init has run in this (dask worker) process


def map_cases(fn: Callable, items: Iterable, *, workers: int | None = None,
              scheduler: str | None = None) -> Iterator[tuple]:
    """``fn(item)`` for each item, yielded as ``(item, result)`` in the order they finish.

    Parameters
    ----------
    fn : callable
        A module-level function (or a ``functools.partial`` of one): it travels to the workers by
        pickle.
    items : iterable
        The cases' arguments, one each (picklable).
    workers : int, optional
        Local worker processes (forked, single-threaded; default: this command's share of the
        cores, :func:`rmbench.threads.default_workers`); 0 or 1 runs the cases here, one after the
        other, in the order given.
    scheduler : str, optional
        Address of an existing dask scheduler: the cases become tasks of its cluster (then
        ``workers`` is ignored). Its workers must import rmbench and ``fn``'s module.

    Yields
    ------
    item, result
        The first exception a case raises is raised here; the cases not yet started are then
        cancelled. Closing the generator early cancels them too.
    """
    items = list(items)
    if scheduler is not None:
        yield from _on_dask(fn, items, scheduler)
        return
    n = default_workers() if workers is None else _check_workers(workers)
    if n <= 1 or len(items) <= 1:
        for item in items:
            yield item, fn(item)
        return
    yield from _on_processes(fn, items, min(n, len(items)))


def worker_pool(workers: int | None = None, *, initializer: Callable | None = None,
                initargs: tuple = ()):
    """A pool of local worker processes, forked and single-threaded.

    Forked: the workers start with this process's imports and objects (a function defined in a
    script, a model built here), so nothing of it is pickled but the calls' arguments. Each worker
    runs :func:`rmbench.threads.worker_init` (one thread in every pool) and then
    ``initializer(*initargs)`` where given (to keep per-worker state, e.g. a rebuilt model).

    Parameters
    ----------
    workers : int, optional
        Processes, at least 1 (default: this command's share of the cores,
        :func:`rmbench.threads.default_workers`).
    initializer : callable, optional
        Run in each worker after it is made single-threaded.
    initargs : tuple
        ``initializer``'s arguments.

    Returns
    -------
    concurrent.futures.ProcessPoolExecutor
        The caller shuts it down (or uses it as a context manager).
    """
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    n = default_workers() if workers is None else _check_workers(workers)
    if n < 1:
        raise InputError("a worker pool needs at least one worker, got 0")
    return ProcessPoolExecutor(max_workers=n, mp_context=mp.get_context("fork"),
                               initializer=_init_worker, initargs=(initializer, initargs))


def _init_worker(initializer, initargs) -> None:
    worker_init()
    if initializer is not None:
        initializer(*initargs)


def _check_workers(workers) -> int:
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 0:
        raise InputError(f"workers must be a whole number >= 0, got {workers!r}")
    return workers


def _on_processes(fn, items, n):
    """Forked processes: they start with this process's imports, and with ``fn`` even where it is
    defined in a script (``__main__``)."""
    from concurrent.futures import as_completed

    pool = worker_pool(n)
    try:
        futures = {pool.submit(fn, item): item for item in items}
        for fut in as_completed(futures):
            yield futures[fut], fut.result()
    except BaseException:   # an error, an interrupt or an early close: the cases not started are dropped
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


def _on_dask(fn, items, scheduler):
    from dask.distributed import Client, as_completed

    client = Client(scheduler)
    futures = []
    try:
        futures = [client.submit(_single_threaded, fn, item, pure=False) for item in items]
        index = {fut.key: i for i, fut in enumerate(futures)}
        for fut in as_completed(futures):
            yield items[index[fut.key]], fut.result()
    finally:
        client.cancel(futures)
        client.close()


def _single_threaded(fn, item):
    """``fn(item)`` on a dask worker, whose process is made single-threaded at its first case."""
    global _SINGLE_THREADED
    if not _SINGLE_THREADED:
        worker_init()
        _SINGLE_THREADED = True
    return fn(item)
