"""Shared fixtures: the bundled robots at a few operating points (built once per session), and one
headless Chromium per test module for the report tests."""

import os

import pytest

from rmbench.report.browser import Browser, find_chromium
from rmbench.robot import Posture, Robot
from rmbench.threads import available_cores, limit_threads


def pytest_configure(config):
    # under pytest-xdist each test process takes its share of the cores for its BLAS and torch
    # pools and for the commands it starts: two processes of two threads each on two cores thrash
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0") or 0)
    if workers > 1:
        limit_threads(max(1, available_cores() // workers))


# The test files that take longest, longest first (one core's seconds in measured runs, from about
# 55 s down to 3 s). make test hands files to its two pytest-xdist workers in collection order
# (--no-loadscope-reorder): heavy files first and the many light ones last, the workers finish
# together; ordered by test count, as xdist does by default, one worker idled ~20 s at the end.
HEAVIEST_FIRST = ("test_parallel.py", "test_report.py", "test_bench_truth.py", "test_any_robot.py", "test_path.py",
                  "test_predict_gp.py", "test_gap_calibrated.py", "test_gap_form.py", "test_truth_tracker.py",
                  "test_predict_cluster.py", "test_gap_diagnose.py", "test_rcsa_cli.py", "test_docs.py",
                  "test_milling_heading.py", "test_cli_json.py", "test_path_corners.py", "test_calibrate_form.py",
                  "test_blind_tracker.py", "test_impact_campaign.py", "test_gap_tracker.py", "test_calibrate.py",
                  "test_path_low_speed.py", "test_demo_low_speed.py", "test_truth_vs_time.py", "test_path_exact_all.py", "test_stability.py", "test_predict_gauge.py",
                  "test_threads.py", "test_modal_campaign.py", "test_modal_fit.py", "test_cli_campaign.py",
                  "test_control_cli.py", "test_control_loop.py", "test_control_sampled.py", "test_modal_robust.py", "test_predict_baselines.py",
                  "test_control_design.py", "test_truth_structural.py")


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(HEAVIEST_FIRST)}
    # a stable sort: each file's tests, and the lighter files, keep their order
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


@pytest.fixture(scope="session")
def irb():
    return Robot.load("irb6660", tool="dummy")


@pytest.fixture(scope="session")
def design():
    """The seed's test design (sensors, hammer, bands), as the campaigns measure it."""
    from rmbench.calibrate import TestDesign
    from rmbench.impact import load_config

    return TestDesign.from_config(load_config("seed_full"))


@pytest.fixture(scope="session")
def irb_op(irb):
    """The IRB6660 stand-in at the seed's first validation posture."""
    return irb.at(Posture.from_mm_deg(1800, -200, 0))


@pytest.fixture(scope="session")
def mh180():
    return Robot.load("mh180")


@pytest.fixture(scope="session")
def op():
    """The MH180 stand-in at its reference posture (the proof-mass suppressor's tests)."""
    from rmbench.robot.suppressor import reference_point

    return reference_point()


@pytest.fixture(scope="session")
def tangential(op):
    """The exact single-axis tangential proof-mass plant (all 38 states): the linear prediction."""
    from rmbench.control import robot_plant

    return robot_plant(op, ("tangential",))


@pytest.fixture(scope="session")
def default_design(op):
    """The default tangential design: plant reduced to 14 states, controller to 12."""
    from rmbench.control import design, robot_plant

    return design(robot_plant(op, ("tangential",), order=14))


@pytest.fixture
def cli(capsys):
    """Run ``rmbench ARGV...`` in-process: returns (exit code, stdout, stderr)."""
    from rmbench.cli import main

    def run(*argv):
        code = main([str(a) for a in argv])
        cap = capsys.readouterr()
        return code, cap.out, cap.err

    return run


@pytest.fixture
def gap_reports(tmp_path):
    """``reports(dg)``: the HTML of a gap diagnosis's report drawn from the result itself and
    from the folder it saved (both with the same title and metadata)."""
    from rmbench.report import Page
    from rmbench.report.gap import gap_sections

    def reports(dg):
        dg.save(tmp_path / "saved")
        pages = []
        for source in (dg, tmp_path / "saved"):
            page = Page("gap", {"data": "d"})
            gap_sections(page, source)
            pages.append(page.html())
        return pages

    return reports


def _missing(why: str):
    """Skip, except where the run demands the browser (.ci/run sets RMBENCH_REQUIRE_BROWSER)."""
    if os.environ.get("RMBENCH_REQUIRE_BROWSER"):
        pytest.fail(why)
    pytest.skip(why)


@pytest.fixture(scope="module")
def browser():
    """One Chromium for the module's pages (through Playwright), or a skip that says what is
    missing (CI installs both)."""
    if find_chromium() is None:
        _missing("Chromium not found: install Debian's chromium package (.ci/run does) to render reports")
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        _missing("playwright not installed: pip install -e '.[test]'")
    with Browser() as b:
        yield b
