"""Threads per process: BLAS, OpenMP and torch pools sized to the process's share of the cores.

rmbench runs parallel work in worker processes (campaign postures, modal fits, blind cases, cuts).
Thread pools sized to the machine in every process oversubscribe the cores (workers × BLAS
threads), and spinning BLAS and OpenMP threads then take turns on a core and thrash (a 12-posture
modal fit on 2 cores: 7 s with single-threaded workers, 65 s with two BLAS threads each). So:

- a command's own pools take its share of the cores: ``RMBENCH_THREADS``, or every core this
  process may run on;
- a command with worker processes starts as many as its share (:func:`default_workers`), each
  single-threaded (:func:`worker_init`, the pool's initializer): one thread per worker also keeps
  the results independent of the number of workers, bit for bit;
- idle OpenMP threads sleep rather than spin (``OMP_WAIT_POLICY=PASSIVE``) so that a job beside
  another does not burn the cores it waits on.
"""

from __future__ import annotations

import os
import sys

from rmbench.errors import InputError

__all__ = ["THREAD_VARIABLES", "available_cores", "process_threads", "default_workers",
           "limit_threads", "one_blas_thread",
           "worker_init", "run_concurrently"]

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                    "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
"""Environment variables that size the thread pools of processes started from this one."""


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity, else the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        return os.cpu_count() or 1


def process_threads() -> int:
    """This command's share of the cores: ``RMBENCH_THREADS``, else :func:`available_cores` or the
    smallest of ``OMP_NUM_THREADS``, ``OPENBLAS_NUM_THREADS``, ``MKL_NUM_THREADS`` where set.

    Raises
    ------
    InputError
        ``RMBENCH_THREADS`` is not a positive whole number.
    """
    raw = os.environ.get("RMBENCH_THREADS")
    if raw is None:
        # a limit the user gave the usual way (OMP_NUM_THREADS=1 ...) stands
        given = [int(v) for v in (os.environ.get(name, "") for name in THREAD_VARIABLES[:3])
                 if v.isdigit() and int(v) > 0]
        return min([available_cores()] + given)
    try:
        n = int(raw)
    except ValueError:
        n = 0
    if n < 1:
        raise InputError(f"RMBENCH_THREADS must be a positive whole number, got {raw!r}")
    return n


def default_workers() -> int:
    """Worker processes of a command that is not told how many: ``RMBENCH_THREADS``, else every
    core this process may run on (``OMP_NUM_THREADS`` and the like size threads, not processes)."""
    return int(os.environ["RMBENCH_THREADS"]) if os.environ.get("RMBENCH_THREADS") else available_cores()


def limit_threads(n: int) -> None:
    """Size this process's BLAS and OpenMP pools (threadpoolctl) and torch's to ``n`` threads, and
    the environment (``RMBENCH_THREADS`` too) so that processes it starts begin with ``n`` as well."""
    from threadpoolctl import threadpool_limits

    for name in THREAD_VARIABLES + ("RMBENCH_THREADS",):
        os.environ[name] = str(n)
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")   # read when an OpenMP runtime loads
    threadpool_limits(limits=n)   # the pools already loaded (numpy's OpenBLAS, scipy's, torch's OpenMP)
    if "torch" in sys.modules:    # torch reads OMP_NUM_THREADS only when it loads
        sys.modules["torch"].set_num_threads(n)


def one_blas_thread(fn):
    """Decorate ``fn`` to run with one BLAS thread in this process.

    For the identification engines, whose matrices are tens to a few hundred wide (a robot's
    46-state eigenproblem, a residual's Jacobian): a second BLAS thread only waits at every call,
    and beside worker processes or other work it waits for a core (a 46 x 46 eigenproblem took 16 ms
    instead of 1.6 ms in a diagnosis beside other processes). Their parallel work is in worker
    processes (:func:`worker_init`).
    """
    import functools

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return wrapper


def worker_init() -> None:
    """Initializer of a worker process: one thread in every pool (a worker owns one core)."""
    limit_threads(1)


def run_concurrently(calls, threads: int | None = None) -> list:
    """Independent calls (no arguments) on up to ``threads`` threads, default this process's
    share of the cores; their results in order, and the first exception raised here.

    For calls that spend their time in compiled code that releases the GIL (torch, BLAS): meanwhile
    the BLAS and torch pools are divided among the threads, so that together they keep to the
    share. The calls must not touch process-wide state (the warnings filters, random seeds drawn
    from, the working folder).
    """
    from concurrent.futures import ThreadPoolExecutor

    from threadpoolctl import threadpool_limits

    calls = list(calls)
    n = min(threads or process_threads(), len(calls))
    if n <= 1:
        return [call() for call in calls]
    torch = sys.modules.get("torch")
    before = torch.get_num_threads() if torch is not None else None
    each = max(1, (before or process_threads()) // n)
    if torch is not None:
        torch.set_num_threads(each)
    try:
        with threadpool_limits(limits=each, user_api="blas"), ThreadPoolExecutor(n) as pool:
            futures = [pool.submit(call) for call in calls]
            return [f.result() for f in futures]
    finally:
        if torch is not None:
            torch.set_num_threads(before)
