"""Campaigns: resumable, reproducible whatever the workers, failures recorded, datasets versioned."""

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.impact import open_campaign, parse_config, run_campaign, save
from rmbench.impact import dataset as dataset_mod

SMALL = """
name = "small"
seed = 11
method = "{method}"
[grid]
kind = "list"
postures = [[1800, -200, 0], [1500, 100, 20], {extra}]
[hits]
points = ["1X", "1aY"]
averages = 1
"""


def _cfg(method="time", extra="[1700, 300, -40]"):
    return parse_config(SMALL.format(method=method, extra=extra))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "ref.nc"
    run_campaign(_cfg(), out, workers=0, progress=False)
    return open_campaign(out)


def test_dataset_follows_the_data_conventions(reference):
    ds = reference
    assert set(ds.H.dims) == {"posture", "freq", "out", "inp"}
    assert list(ds.out.values) == ["1X", "1Y", "1aX", "1aY"]
    assert set(np.unique(ds.band.values)) == {"low", "high"}
    for name in ("coherence", "q_cmd", "H_exact", "H_exact_bare", "modal_exact", "modal_exact_bare"):
        assert name in ds
    assert ds.attrs["seed"] == 11 and "rmbench_version" in ds.attrs and "config" in ds.attrs
    # columns not hit stay unmeasured; hit columns are finite
    assert np.all(np.isnan(ds.H.sel(inp="1Y").values))
    assert np.all(np.isfinite(ds.H.sel(inp="1X").values))


def test_killed_campaign_resumes_and_equals_an_uninterrupted_run(tmp_path, reference, monkeypatch):
    out = tmp_path / "resumed.nc"
    real_write = dataset_mod.PartStore.write
    calls = []

    def write_then_die(self, result):
        real_write(self, result)
        calls.append(result["index"])
        if len(calls) == 1:
            raise KeyboardInterrupt  # the user pressed Ctrl-C after the first posture

    monkeypatch.setattr(dataset_mod.PartStore, "write", write_then_die)
    with pytest.raises(KeyboardInterrupt):
        run_campaign(_cfg(), out, workers=0, progress=False)
    assert not out.exists()  # nothing half-written
    assert len(list((tmp_path / "resumed.nc.parts").glob("posture_*.npz"))) == 1
    monkeypatch.setattr(dataset_mod.PartStore, "write", real_write)
    recomputed = []
    monkeypatch.setattr("rmbench.impact.campaign.run_posture",
                        _spy(recomputed, __import__("rmbench.impact.campaign", fromlist=["x"]).run_posture))
    run_campaign(_cfg(), out, workers=0, progress=False)
    assert sorted(recomputed) == [1, 2]  # the finished posture was not recomputed
    ds = open_campaign(out)
    np.testing.assert_array_equal(ds.H.values, reference.H.values)
    assert not (tmp_path / "resumed.nc.parts").exists()


def _spy(log, fn):
    def wrapped(campaign, index, posture):
        log.append(index)
        return fn(campaign, index, posture)
    return wrapped


def test_results_do_not_depend_on_the_number_of_workers(tmp_path, reference):
    # bit for bit between worker counts (each worker single-threaded); against the in-process
    # run, whose linear algebra may use several BLAS threads, to round-off
    one, two = tmp_path / "one.nc", tmp_path / "two.nc"
    run_campaign(_cfg(), one, workers=1, progress=False)
    run_campaign(_cfg(), two, workers=2, progress=False)
    np.testing.assert_array_equal(open_campaign(two).H.values, open_campaign(one).H.values)
    np.testing.assert_allclose(open_campaign(two).H.values, reference.H.values, rtol=1e-10)


def test_a_dask_scheduler_runs_the_same_campaign(tmp_path):
    # scale-out: the postures as tasks of an existing dask cluster give the local run's dataset
    from dask.distributed import LocalCluster

    local, remote = tmp_path / "local.nc", tmp_path / "remote.nc"
    run_campaign(_cfg(method="linear"), local, workers=1, progress=False)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=50) as cluster:
        run_campaign(_cfg(method="linear"), remote, scheduler=cluster.scheduler_address, progress=False)
    np.testing.assert_array_equal(open_campaign(remote).H.values, open_campaign(local).H.values)


def test_a_failing_posture_is_recorded_and_the_others_run(tmp_path):
    out = tmp_path / "fail.nc"
    run_campaign(_cfg(method="linear", extra="[3500, 0, 0]"), out, workers=0, progress=False)
    ds = open_campaign(out)
    assert list(ds.ok.values) == [True, True, False]
    assert "unreachable" in str(ds.reason.values[2])
    assert np.all(np.isnan(ds.H.values[2]))


def _count_postures(monkeypatch) -> list:
    import rmbench.impact.campaign as campaign_mod

    log = []
    monkeypatch.setattr(campaign_mod, "run_posture", _spy(log, campaign_mod.run_posture))
    return log


def test_rerunning_a_finished_campaign_simulates_nothing(tmp_path, monkeypatch):
    out = tmp_path / "done.nc"
    run_campaign(_cfg(method="linear"), out, workers=0, progress=False)
    before = out.stat().st_mtime_ns
    log = _count_postures(monkeypatch)
    run_campaign(_cfg(method="linear"), out, workers=0, progress=False)
    assert log == [] and out.stat().st_mtime_ns == before


def test_a_finished_dataset_of_another_config_is_simulated_again(tmp_path, monkeypatch):
    out = tmp_path / "other.nc"
    run_campaign(_cfg(method="linear"), out, workers=0, progress=False)
    log = _count_postures(monkeypatch)
    run_campaign(_cfg(method="linear", extra="[1600, 0, 0]"), out, workers=0, progress=False)
    assert sorted(log) == [0, 1, 2]
    assert open_campaign(out).x.values[2] == pytest.approx(1.6)


def test_force_simulates_a_finished_campaign_again(tmp_path, monkeypatch):
    out = tmp_path / "forced.nc"
    run_campaign(_cfg(method="linear"), out, workers=0, progress=False)
    log = _count_postures(monkeypatch)
    run_campaign(_cfg(method="linear"), out, workers=0, progress=False, force=True)
    assert sorted(log) == [0, 1, 2]


def test_parts_of_another_config_are_not_mixed_in(tmp_path):
    out = tmp_path / "x.nc"
    (tmp_path / "x.nc.parts").mkdir()
    (tmp_path / "x.nc.parts" / "campaign.json").write_text('{"digest": "other", "n_postures": 3}')
    with pytest.raises(InputError, match="another configuration"):
        run_campaign(_cfg(method="linear"), out, workers=0, progress=False)


def test_dataset_of_a_newer_version_is_rejected_naming_both(tmp_path, reference):
    path = tmp_path / "future.nc"
    save(reference.assign_attrs(rmbench_dataset_version=99), path)
    with pytest.raises(InputError, match="version 99.*reads version 1"):
        open_campaign(path)


def test_unreadable_dataset_is_a_clear_error(tmp_path):
    path = tmp_path / "junk.nc"
    path.write_bytes(b"not a netCDF file")
    with pytest.raises(InputError, match="cannot read dataset"):
        open_campaign(path)


def test_modes_are_tracked_consistently_across_postures(reference):
    # DATA.md: modes are numbered by frequency at the first posture (a mode that appears only
    # later gets a later number), and a tracked mode moves by less than the workspace spread
    # (25 %) between neighbouring postures
    f = reference.modal_exact.sel(param="f_n").values
    bands = reference.mode_band.values
    for b in ("low", "high"):
        first = f[0, bands == b]
        seen = first[np.isfinite(first)]
        assert len(seen) >= 4 and np.all(np.diff(seen) > 0)
        assert np.all(np.isfinite(first[:len(seen)]))  # the first posture's modes come first
    jumps = np.abs(np.diff(f, axis=0)) / f[:-1]
    assert np.nanmax(jumps) < 0.25
