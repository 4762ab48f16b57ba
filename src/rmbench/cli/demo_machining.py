"""The demo's machining steps: lobes at one posture, and the bundled contour planned and milled:
at high speed in aluminium from the demo's predictor, and at low speed in steel on the exact model,
where the robot's own modes set the limit and θ turns at the corners (issue 82)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["demo_lobes", "demo_path", "demo_low_speed", "low_speed_plan", "mill_low_speed"]

#: the low-speed step's spindle speeds (evenly over ``SPEED_RANGES["low"]``), path spacing (m) and
#: angle grid (deg): coarse, so that the exact model's plan and 6 cuts take well under a minute
LOW_SPEEDS = 4
LOW_SPACING = 30e-3
LOW_THETA_DEG = (-60.0, 61.0, 10.0)


def demo_lobes(out: Path, fit, page) -> None:
    """Stability lobes at (1800, 200, 0) from the campaign's fitted modes against the exact modes."""
    from rmbench.robot import Posture, Robot
    from rmbench.stability import (ALUMINIUM_6061, Structure, compare_lobes, depth_grid, lobes, lowest_envelope,
                                   speed_grid)
    from rmbench.stability.plot import plot_lobes

    print("\nstability lobes at (1800, 200, 0), aluminium 6061 slot, 2 teeth (FDM, both bands, lowest "
          "envelope): from the campaign's fitted modes and from the exact modes")
    op = Robot.load("irb6660", tool="dummy").at(Posture.from_mm_deg(1800, 200, 0))
    speeds, depths = speed_grid("robot", 40), depth_grid()
    env = {}
    for name, make in (("fitted", lambda b: Structure.from_modal(fit, 1, band=b)),
                       ("exact", lambda b: Structure.from_mode_table(op.modes(b)))):
        env[name] = lowest_envelope(*(lobes(make(b), ALUMINIUM_6061, speeds, depths, every=5)
                                      for b in ("low", "high")))
    c = compare_lobes(env["fitted"], env["exact"])
    print(f"  lowest critical depth {1e3 * c['a_lim_min_reference']:.3f} mm (exact), "
          f"{1e3 * c['a_lim_min']:.3f} mm (fitted); fitted vs exact over {c['n_speeds']} speeds: "
          f"median {100 * c['rel_err_median']:.2f} %, max {100 * c['rel_err_max']:.2f} %")
    print(f"  wrote {plot_lobes(env, out / 'lobes.png', title='IRB6660 stand-in, dummy tool, (1800, 200, 0)')}")
    from rmbench.report.machining import lobes_sections

    page.part("Milling stability")
    lobes_sections(page, env, title="Lobes at (1800, 200, 0): fitted against exact modes",
                   note="Aluminium 6061 slot, 2 teeth, FDM over both bands, lowest envelope; from the "
                        "campaign's fitted modes and from the simulator's exact modes.")


def demo_path(out: Path, page) -> None:
    """Tool path: the bundled contour planned from the demo's predictor (the dummy tool's dynamics),
    its depth's band, and virtual milling of both schedules at a depth between their limits."""
    from rmbench.path import PlanSettings, example, mill_schedule, plan_path, with_band
    from rmbench.predict import PosturePredictor
    from rmbench.report.path import path_sections
    from rmbench.robot import Robot

    print("\ntool path: the bundled 400 x 400 mm contour, redundant angle chosen at each cutter location from -60 to 60 "
          "degrees for the largest smallest critical depth at 9000 rev/min (aluminium 6061 slot), from the "
          "predictor above")
    robot = Robot.load("irb6660", tool="dummy")
    predictor = PosturePredictor.load(out / "demo_predictor.npz")
    plan = plan_path(robot, predictor, example("contour"), speed_rpm=9000.0,
                     settings=PlanSettings(theta=tuple(np.radians(np.arange(-60.0, 61.0, 10.0))), spacing=10e-3))
    plan = with_band(plan, predictor, draws=32)
    s = plan.to_dict()
    a = s["min_alim_mm"]
    print(f"  {s['cl_points']} cutter locations x {len(plan.reach.theta)} angles in {s['seconds']['total']:.1f} s: "
          f"smallest critical depth planned {a['planned']:.3f} mm (95 % band down to {s['band']['min_lower_mm']:.3f}), "
          f"theta held at 0 {a['fixed']:.3f} mm (gain {s['min_alim_gain']:.2f}x), each location's best "
          f"{a['pointwise']:.3f} mm")
    print(f"wrote {plan.to_csv(out / 'demo_path_plan.csv')}")
    # a depth between the two schedules' smallest limits: where they differ the plan should hold
    depth = 0.5 * (plan.planned.min_margin + plan.fixed.min_margin)
    milled = {}
    for sched in ("planned", "fixed"):
        milled[sched] = mill_schedule(robot, plan, depth=depth, schedule=sched, n=3)
        m = milled[sched].summary()
        agree = "" if m["agreement"] is None else f", {100 * m['agreement']:.0f} % of them as planned"
        print(f"  milled 3 locations of the {sched} schedule at {1e3 * depth:.2f} mm: {m['chatter']} chatter "
              f"({m['expected_chatter']} expected; {m['decided']} clear of the predicted depth's ±10 %{agree})")
    page.part("Tool path: the contour planned and milled")
    path_sections(page, plan, milled)



def low_speed_plan(robot, reorient: str = "corners"):
    """The bundled contour planned for steel C45 at :data:`LOW_SPEEDS` speeds over 300-3,000 rev/min,
    the feed along the path, θ re-oriented by ``reorient``, on every mode of the robot's exact
    linear model below 8 kHz (those the virtual milling sees, the tool's included)."""
    from rmbench.path import PlanSettings, example, plan_path
    from rmbench.stability import STEEL_C45, speed_grid

    settings = PlanSettings(theta=tuple(np.radians(np.arange(*LOW_THETA_DEG))), spacing=LOW_SPACING,
                            eval_spacing=LOW_SPACING, feed="path", reorient=reorient, exact_modes="all")
    return plan_path(robot, None, example("contour"), speed_rpm=speed_grid("low", LOW_SPEEDS), cutting=STEEL_C45,
                     settings=settings)


def mill_low_speed(robot, plan, depth: float) -> dict:
    """Three cuts of the planned schedule and of the best fixed angle's at ``depth`` (m), at the same
    locations: the first, middle and last of those where the best fixed angle's critical depth lies
    below ``depth`` (evenly along the path where fewer than three do). Returns ``{"planned":
    PathMilling, "best fixed": PathMilling}``; raises the milling's ``InputError`` where it refuses
    the plan."""
    from dataclasses import replace

    from rmbench.path import mill_schedule

    risk = replace(plan, depth=depth).at_risk(plan.best_fixed)
    where = {"locations": risk[[0, len(risk) // 2, -1]]} if len(risk) >= 3 else {"n": 3}
    return {"planned": mill_schedule(robot, plan, depth=depth, **where),
            # the best fixed angle milled as the plan's comparison schedule
            "best fixed": mill_schedule(robot, replace(plan, fixed=plan.best_fixed), depth=depth, schedule="fixed",
                                        **where)}


def demo_low_speed(out: Path, page) -> None:
    """Low-speed tool path: the contour in steel at 300-3,000 rev/min on the exact model, θ turned
    standing at the corners; milled at a depth between the plan's and the best fixed angle's limits."""
    from rmbench.report.path import path_sections, segments_section
    from rmbench.robot import Robot

    print(f"\nlow-speed tool path: the same contour in steel C45 (6 teeth, half immersion, climb), "
          f"{LOW_SPEEDS} speeds over 300-3,000 rev/min, the feed along the path, θ every {LOW_THETA_DEG[2]:g} "
          "degrees from -60 to 60 and turned at the corners with the tool standing; planned on every mode of the "
          "exact model below 8 kHz, the tool's included (those the milling sees)")
    robot = Robot.load("irb6660", tool="dummy")
    plan = low_speed_plan(robot)
    _print_low_speed(plan)
    print(f"wrote {plan.to_csv(out / 'demo_low_speed_plan.csv')}")
    depth = 0.5 * (plan.planned.min_margin + plan.best_fixed.min_margin)
    milled = mill_low_speed(robot, plan, depth)
    for name, m in milled.items():
        d = m.summary()
        agree = "" if d["agreement"] is None else f", {100 * d['agreement']:.0f} % of them as planned"
        print(f"  milled {d['cuts']} locations of the {name} schedule at {d['depth_mm']:.3f} mm on the moving robot "
              "(where the best fixed angle's limit lies below it): "
              f"{d['chatter']} chatter ({d['expected_chatter']} expected; {d['decided']} clear of the critical "
              f"depth's ±10 %{agree})")
    page.part("Low-speed tool path: the contour in steel, planned on the exact model and milled")
    segments_section(page, plan, milled)
    path_sections(page, plan, milled)


def _print_low_speed(plan) -> None:
    """The low-speed plan's figures: speed, limits, gain over the best fixed angle, corners."""
    s = plan.to_dict()
    a, bf = s["min_alim_mm"], s["best_fixed"]
    print(f"  {s['cl_points']} cutter locations x {len(plan.reach.theta)} angles x {LOW_SPEEDS} speeds in "
          f"{s['seconds']['total']:.1f} s: best speed {plan.speed_rpm:g} rev/min (planned smallest critical depth "
          + ", ".join(f"{v:.3f}" for v in s["speed_scan"]["min_alim_mm"]) + " mm at "
          + ", ".join(f"{v:g}" for v in s["speed_scan"]["speeds_rpm"]) + " rev/min)")
    print(f"  smallest critical depth planned {a['planned']:.3f} mm; the best fixed angle, theta = "
          f"{bf['theta_deg']:g} deg, {bf['min_alim_mm']:.3f} mm (gain {s['min_alim_gain_best_fixed']:.2f}x); "
          f"theta held at 0 {a['fixed']:.3f} mm")
    if plan.reorientation is not None:
        print(f"  {plan.reorientation.summary()}")
