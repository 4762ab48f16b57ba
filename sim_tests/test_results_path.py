"""A path plan describes itself: summary(), to_dict() and plot(), on a small plan made by hand."""

import json

import numpy as np
import pytest

from rmbench.io.toolpath import ToolPath
from rmbench.path import DepthBand, DepthGrid, PathPlan, Reach, fixed_schedule, plan_schedule, pointwise_schedule


@pytest.fixture(scope="module")
def plan():
    """Six locations along a 50 mm line at 3 m/min, three angles; θ = 0 cannot reach the fourth
    location, so the fixed-θ schedule's smallest depth is -inf (its gain unbounded)."""
    n, theta = 6, np.radians([-20.0, 0.0, 20.0])
    xy = np.column_stack([1.5 + 0.01 * np.arange(n), np.zeros(n)])
    tp = ToolPath(xy, np.zeros(n), np.full(n, 0.05), np.full(n, 9000.0), np.array([False] + [True] * (n - 1)),
                  np.arange(1, n + 1))
    q = np.zeros((n, 3, 2)) + theta[None, :, None]
    ok = np.ones((n, 3), bool)
    ok[3, 1] = False
    reach = Reach(theta, q, ok, np.full((n, 3), 0.1), np.full((n, 3), 0.5))
    a_lim = np.array([[2e-3, 3e-3, 2.5e-3]] * n)
    depths = DepthGrid(a_lim, {"low": a_lim}, np.zeros((n, 3), bool), 9000.0)
    margin = np.where(ok, a_lim, -np.inf)
    planned = plan_schedule(margin, theta, q=q, max_step=2, max_dq=1.0)
    band = DepthBand(planned.margin, 0.8 * planned.margin, 1.2 * planned.margin, 1.0, 0)
    return PathPlan(tp, reach, depths, planned, fixed_schedule(margin, theta, 0.0), pointwise_schedule(margin, theta),
                    2.2e-3, 9000.0, {"total": 0.1}, np.zeros(n), band=band)


def test_a_plans_summary_names_its_locations_depths_and_risk_in_mm(plan):
    text = plan.summary()
    assert isinstance(text, str) and text.startswith("6 cutter locations at 9000 rev/min")
    assert "planned 2.500 mm, fixed θ = 0° unusable, pointwise best 2.500 mm" in text
    assert "95 % band of the planned critical depth: smallest lower bound 2.000 mm" in text
    assert "locations below the 2.2 mm depth: planned 0, fixed 1" in text


def test_a_plans_dict_is_strict_json_with_null_for_the_unbounded(plan):
    d = plan.to_dict()
    back = json.loads(json.dumps(d, allow_nan=False))
    assert back["cl_points"] == 6 and back["min_alim_mm"]["planned"] == pytest.approx(2.5)
    assert back["min_alim_mm"]["fixed"] is None and back["min_alim_gain"] is None
    assert back["at_risk"] == {"planned": 0, "fixed": 1, "planned_band": 1}     # 0.8 x 2.5 mm < 2.2 mm


def test_a_plan_plots_its_critical_depth_along_the_path(plan):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax = plan.plot()
    assert len(ax.lines) >= 2 and ax.get_xlabel() == "arc length (mm)"
    _, given = plt.subplots()
    assert plan.plot(ax=given) is given
    plt.close("all")
