"""Independent cases on worker pools (rmbench.parallel): here, local processes or a dask cluster give
the same results, and the blind check and the calibration bench run on a cluster write the lines of a
run here."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from rmbench.errors import InputError
from rmbench.gap.cases.blind import run_blind
from rmbench.parallel import map_cases, worker_pool


def _square(x):
    return x * x, max(p["num_threads"] for p in threadpool_info())


def _fail_on_three(x):
    return 1 / (x - 3)


@pytest.fixture(scope="module")
def cluster():
    """Two single-threaded worker processes, without dask's statistical profiler (it samples each
    worker's stack every 10 ms, a diagnostic these tests never read: CPU taken from the cases), and
    with its other monitors slowed: the event-loop tick (every 20 ms in each process, it only warns
    of a blocked loop), the memory monitor (every 100 ms, it spills, pauses or restarts a worker
    near its memory limit, which these cases are far below) and the system monitor (every 500 ms,
    CPU and network figures for the dashboard there is none of). Measured idle, default intervals
    took 0.07 s of CPU a second, these 0.01."""
    import dask
    from dask.distributed import LocalCluster

    quiet = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
             "distributed.worker.memory.monitor-interval": "1s",
             "distributed.admin.system-monitor.interval": "2s"}
    with dask.config.set(quiet), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                         silence_logs=50) as c:
        yield c.scheduler_address


def _pool(where, request) -> dict:
    """map_cases's keywords for running here, on two local processes or on the test's cluster."""
    if where == "dask":
        return {"scheduler": request.getfixturevalue("cluster")}
    return {"workers": 0 if where == "here" else 2}


@pytest.mark.parametrize("where", ["here", "processes", "dask"], ids=["here", "processes", "dask"])
def test_every_case_comes_back_once_with_its_result(where, request):
    got = list(map_cases(_square, range(6), **_pool(where, request)))
    assert sorted((x, r[0]) for x, r in got) == [(x, x * x) for x in range(6)]


@pytest.mark.parametrize("where", ["processes", "dask"], ids=["processes", "dask"])
def test_workers_run_single_threaded(where, request):
    assert {r[1] for _, r in map_cases(_square, range(4), **_pool(where, request))} == {1}


def test_cases_run_here_come_back_in_the_order_given():
    assert [x for x, _ in map_cases(_square, [3, 1, 2], workers=1)] == [3, 1, 2]


@pytest.mark.parametrize("workers", [0, 2], ids=["here", "processes"])
def test_a_failing_case_raises_its_error(workers):
    with pytest.raises(ZeroDivisionError):
        list(map_cases(_fail_on_three, range(5), workers=workers))


@pytest.mark.parametrize("workers", [-1, 1.5, True], ids=["negative", "fraction", "bool"])
def test_workers_must_be_a_whole_number(workers):
    with pytest.raises(InputError, match="workers must be a whole number"):
        list(map_cases(_square, range(2), workers=workers))


_KEPT: dict = {}


def _keep(value):
    _KEPT["value"] = value


def _kept_and_threads(_):
    return _KEPT.get("value"), max(p["num_threads"] for p in threadpool_info())


def test_a_worker_pool_runs_its_initializer_in_single_threaded_workers():
    with threadpool_limits(limits=2), worker_pool(2, initializer=_keep, initargs=("model",)) as pool:
        got = list(pool.map(_kept_and_threads, range(4)))
    assert got == [("model", 1)] * 4


def test_a_worker_pool_without_an_initializer_is_single_threaded():
    with threadpool_limits(limits=2), worker_pool(1) as pool:
        assert pool.submit(_square, 3).result() == (9, 1)


@pytest.mark.parametrize("workers", [0, -1], ids=["none", "negative"])
def test_a_worker_pool_needs_a_worker(workers):
    with pytest.raises(InputError):
        worker_pool(workers)


def _lines(path) -> set:
    """The JSON lines of a blind run without their timing."""
    cases = [json.loads(s) for s in path.read_text().splitlines() if s.strip()]
    return {json.dumps({k: v for k, v in c.items() if k != "seconds"}, sort_keys=True) for c in cases}


BLIND_POSTURES = 2


@pytest.fixture(scope="module")
def local_blind(tmp_path_factory):
    """One small blind case (a 2-posture linear campaign) run here, single-threaded as a bench
    runs it (OMP_NUM_THREADS=1): its JSON line. (With more BLAS threads here the held-out
    shrink differs from a single-threaded worker's in its 13th digit.) Two postures, the fewest
    a diagnosis takes: the case goes the whole way at any count (draw, campaign, UFF58 and back,
    diagnosis, score; seed 5's is explained), and what these tests check is where it ran, not
    how well it diagnoses (the cluster runs it too: 2 postures take 6-7 s of CPU a run, 4 took 11)."""
    out = tmp_path_factory.mktemp("blind") / "local.jsonl"
    with threadpool_limits(limits=1):
        run_blind(1, 5, method="linear", workers=0, n_postures=BLIND_POSTURES, out=out)
    return out


@pytest.mark.slow
def test_blind_cases_on_a_dask_cluster_write_the_lines_of_a_run_here(local_blind, cluster, tmp_path):
    remote = tmp_path / "remote.jsonl"
    report = run_blind(1, 5, method="linear", n_postures=BLIND_POSTURES, scheduler=cluster, out=remote)
    assert _lines(remote) == _lines(local_blind)
    assert [c.index for c in report.cases] == [0]


def test_a_blind_run_on_a_cluster_resumes_without_running_the_cases_written(local_blind, cluster, tmp_path):
    # the case the file holds is read back, not run again (running it is the test above)
    remote = tmp_path / "resumed.jsonl"
    remote.write_text(local_blind.read_text())
    ran = []
    report = run_blind(1, 5, method="linear", n_postures=BLIND_POSTURES, scheduler=cluster, out=remote,
                       progress=lambda case: ran.append(case.index))
    assert ran == []
    assert [c.index for c in report.cases] == [0]
    assert _lines(remote) == _lines(local_blind)


def test_tracker_blind_cases_on_a_dask_cluster_write_the_lines_of_a_run_here(cluster, tmp_path):
    from rmbench.gap.cases.tracker_blind import run_tracker_blind

    # two cases, the fewest that can finish out of order on the two workers: the run gives them
    # back in index order however they come
    small = {"n_config": 120, "levels": False, "n_workspace": 2000}
    local, remote = tmp_path / "local.jsonl", tmp_path / "remote.jsonl"
    with threadpool_limits(limits=1):
        run_tracker_blind(2, 3, out=local, **small)
    cases = run_tracker_blind(2, 3, out=remote, scheduler=cluster, **small)
    assert _lines(remote) == _lines(local)
    assert [c["index"] for c in cases] == [0, 1]


CALIBRATION_BENCH = Path(__file__).resolve().parents[1] / "bench" / "calibrate.py"


def _calibration_bench(tmp_path, name, *extra):
    """The calibration bench's smallest run (one rigid robot, a 5-posture campaign in the
    frequency domain, 1 held out, the joints alone calibrated, checked at 4 unseen postures: each
    step of a bench case, measure, fit, calibrate and score), started as a command: bench/ never on
    this process's path (none of its scripts may shadow a library). Five postures, the fewest the
    bench takes: what this checks is where the case ran (its lines the same bit for bit on the
    cluster as here), not how well it calibrates, and every step runs the same code at any count;
    8 postures and 16 unseen took 9.7 s of CPU a run, this 5.8. Its own cache folder, so the
    campaign is measured where the case runs. The started process: its ``finish()`` waits for it
    and gives its JSON-lines file and its last printed line."""
    lines = tmp_path / f"{name}.jsonl"
    out, err = tmp_path / f"{name}.out", tmp_path / f"{name}.err"
    with open(out, "w") as fo, open(err, "w") as fe:
        # one process each: the two runs and the other test worker already share the two cores
        run = subprocess.Popen([sys.executable, str(CALIBRATION_BENCH), "--robots", "1", "--seed", "1", "--plain",
                                "--workers", "1", "--method", "linear", "--groups", "joints", "--unseen", "4", "--campaign", "5",
                                "--lines", str(lines), "--cache", str(tmp_path / f"{name}_cache"), *extra],
                               env={**os.environ, "OMP_NUM_THREADS": "1"}, stdout=fo, stderr=fe)

    def finish() -> tuple:
        try:
            code = run.wait()
        except BaseException:       # interrupted here: the command goes too
            run.kill()
            run.wait()
            raise
        if code:
            raise subprocess.CalledProcessError(code, run.args, out.read_text(), err.read_text())
        return lines, json.loads(out.read_text().strip().splitlines()[-1])

    run.finish = finish
    return run


@pytest.mark.slow
def test_the_calibration_bench_on_a_dask_cluster_writes_the_lines_of_a_run_here(cluster, tmp_path):
    from dask.distributed import Client, get_task_stream

    # the run here goes on beside the cluster's (its own process, files and cache): the cluster
    # does not wait idle through it
    local = _calibration_bench(tmp_path, "local")
    try:
        with Client(cluster) as client, get_task_stream(client) as stream:
            remote_lines, remote_last = _calibration_bench(tmp_path, "remote", "--scheduler", cluster).finish()
    except BaseException:
        local.kill()
        local.wait()
        raise
    local_lines, local_last = local.finish()
    # the robot ran on the cluster (one case, one task of its workers), and was calibrated in both
    assert [t["key"].startswith("_single_threaded") for t in stream.data] == [True]
    assert local_last["cases"] == 1
    # wall-clock seconds alone may differ: a case's "seconds" (measure, calibrate, score) in the
    # lines, and the last line's "calibrate_s" (the median of those calibrate seconds)
    assert _lines(remote_lines) == _lines(local_lines)
    assert {k: v for k, v in remote_last.items() if k != "calibrate_s"} \
        == {k: v for k, v in local_last.items() if k != "calibrate_s"}
