"""``rmbench demo``: the main job on an embedded default.

For now: the exact ground truth of the IRB6660 stand-in at the seed's three validation postures,
their mode tables, and a plot of the exact tool-tip FRFs in both bands.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["register"]


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the main job on an embedded default and plot it")
    p.add_argument("--out", default="rmbench_demo", help="directory for the figures (default rmbench_demo)")
    p.set_defaults(func=cmd_demo)


def cmd_demo(args) -> int:
    from rmbench.robot import Robot, validation_postures
    from rmbench.robot.plot import plot_tip_frfs

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    robot = Robot.load("irb6660", tool="dummy")
    print(f"rmbench demo: exact ground truth of the {robot.name} stand-in with the {robot.tool} tool")
    curves = {"low": [], "high": []}
    for p in validation_postures():
        op = robot.at(p)
        print(f"\nposture {p.label()} (x mm, y mm, theta deg): q_cmd = "
              + ", ".join(f"{np.degrees(q):.2f}" for q in op.q_cmd) + " deg")
        for band in ("low", "high"):
            b = robot.bands[band]
            t = op.modes(band)
            modes = ", ".join(f"{f:.2f} Hz ({100 * z:.1f} %)" for f, z in zip(t.f_n, t.zeta))
            print(f"  {band:>4} band modes: {modes}")
            freq = np.linspace(b.f_min, b.f_max, 2000)
            curves[band].append((p.label(), freq, op.frf(freq, s_1a=b.s_1a)))
    for band in ("low", "high"):
        path = out / f"exact_tip_frf_{band}.png"
        plot_tip_frfs(curves[band], path, title=f"Exact tool-tip receptance, {band} band, IRB6660 stand-in")
        print(f"\nwrote {path}")
    return 0
