"""Thread pools within a process's share of the cores: a command's share (RMBENCH_THREADS or its
cores) for its own pools, one thread for each of its workers, so that workers and jobs side by side do
not oversubscribe the cores."""

import json
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from rmbench.threads import available_cores, process_threads, run_concurrently, worker_init


def _pool_threads():
    return [p["num_threads"] for p in threadpool_info()]


def test_a_forked_worker_runs_single_threaded_whatever_its_parent_uses():
    # a forked worker inherits the parent's BLAS pool size; two workers of two threads each on
    # two cores is the oversubscription that made the modal fit 9x slower
    with threadpool_limits(limits=2):
        with ProcessPoolExecutor(max_workers=1, initializer=worker_init) as pool:
            threads = pool.submit(_pool_threads).result()
    assert threads and all(n == 1 for n in threads)


def test_a_commands_share_is_its_cores_unless_rmbench_threads_says_otherwise(monkeypatch):
    for name in ("RMBENCH_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.delenv(name, raising=False)
    assert process_threads() == available_cores()
    monkeypatch.setenv("OMP_NUM_THREADS", "1")   # a limit given the usual way stands
    assert process_threads() == 1
    monkeypatch.setenv("RMBENCH_THREADS", "3")
    assert process_threads() == 3


def _in_child(code: str, **env) -> dict:
    import os

    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, **env})
    return json.loads(out.stdout)


def test_limit_threads_sizes_blas_torch_and_the_environment_of_child_processes():
    # and idle OpenMP threads sleep (OMP_WAIT_POLICY) instead of spinning on a core another job needs
    code = """
import json, os
import numpy, torch
from threadpoolctl import threadpool_info
from rmbench.threads import limit_threads, THREAD_VARIABLES
limit_threads(1)
print(json.dumps({"blas": [p["num_threads"] for p in threadpool_info()], "torch": torch.get_num_threads(),
                  "env": [os.environ[v] for v in THREAD_VARIABLES], "wait": os.environ["OMP_WAIT_POLICY"]}))
"""
    got = _in_child(code, OMP_NUM_THREADS="2", OPENBLAS_NUM_THREADS="2")
    assert all(n == 1 for n in got["blas"]) and got["torch"] == 1 and set(got["env"]) == {"1"}
    assert got["wait"] == "PASSIVE"


def test_torch_loaded_after_the_limit_starts_with_it():
    code = """
import json
from rmbench.threads import limit_threads
limit_threads(1)
import torch
print(json.dumps({"torch": torch.get_num_threads()}))
"""
    assert _in_child(code)["torch"] == 1


@pytest.mark.parametrize("value", ["0", "two", "-1"])
def test_a_bad_rmbench_threads_is_a_one_line_error(value):
    import os

    proc = subprocess.run([str(Path(sys.executable).with_name("rmbench")), "campaign", "export", "nowhere.nc", "--uff", "x"], capture_output=True,
                          text=True, env={**os.environ, "RMBENCH_THREADS": value})
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "RMBENCH_THREADS must be a positive whole number" in proc.stderr


def test_concurrent_calls_return_in_order_and_restore_the_thread_pools():
    import torch

    before = torch.get_num_threads(), [p["num_threads"] for p in threadpool_info()]
    out = run_concurrently([lambda k=k: k * k for k in range(5)], threads=2)
    assert out == [0, 1, 4, 9, 16]
    assert (torch.get_num_threads(), [p["num_threads"] for p in threadpool_info()]) == before


def test_a_failing_concurrent_call_raises_its_own_error():
    def bad():
        raise ValueError("this learner failed")

    with pytest.raises(ValueError, match="this learner failed"):
        run_concurrently([lambda: 1, bad], threads=2)
