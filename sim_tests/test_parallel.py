"""Independent cases on worker pools (rmbench.parallel): here, local processes or a dask cluster give
the same results."""

import json

import pytest
from threadpoolctl import threadpool_info

from rmbench.errors import InputError
from rmbench.parallel import map_cases


def _square(x):
    return x * x, max(p["num_threads"] for p in threadpool_info())


def _fail_on_three(x):
    return 1 / (x - 3)


@pytest.fixture(scope="module")
def cluster():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
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
