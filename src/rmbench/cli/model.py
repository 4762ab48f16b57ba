"""``rmbench model info``, ``variant`` and ``build`` (``calibrate`` and ``suggest``: :mod:`rmbench.cli.calibrate`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rmbench.cli._common import add_robot_options, command_group, load_robot, print_json, resolve_posture
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    msub = command_group(sub, "model", "robot models: exact modes, variants, any arm from URDF")
    info = msub.add_parser("info", help="exact mode table of a robot at a posture")
    add_robot_options(info)
    info.add_argument("--band", choices=("low", "high", "both"), default="both")
    info.add_argument("--json", action="store_true", help="print JSON instead of a table")
    info.set_defaults(func=cmd_info)

    var = msub.add_parser("variant", help="derive a robot variant by editing its specification")
    add_robot_options(var, posture=False)
    var.add_argument("--set", dest="edits", action="append", default=[], metavar="EDIT",
                     help="TARGET.FIELD(=|*=|+=)VALUE, e.g. j2_flex.stiffness*=0.8 or a2.kp*=0.8 (repeatable)")
    var.add_argument("--add-mass", action="append", default=[], metavar="WHERE:KG[:DX,DY,DZ]",
                     help="point mass (kg) at a site or body, offset in m (repeatable)")
    var.add_argument("--compliant-base", default=None, metavar="K_LAT,K_TILT",
                     help="mount on a compliant foundation: lateral N/m, tilt N m/rad")
    var.add_argument("--load-stiffness", action="append", default=[], metavar="JOINT:ALPHA",
                     help="joint stiffness grows with its gravity deflection: k0 (1 + ALPHA |defl| / 1 mrad), "
                          "e.g. j2_flex:0.2 (repeatable, or comma-separated)")
    var.add_argument("--out", required=True, help="MJCF file to write")
    var.set_defaults(func=cmd_variant)

    b = msub.add_parser("build", help="turn a URDF arm (example-robot-data name or file) into a bench robot")
    b.add_argument("--urdf", required=True, metavar="NAME|PATH",
                   help="example-robot-data name (ur10, panda, ...) or a URDF file")
    b.add_argument("--out", required=True, help="MJCF file to write (a starter campaign TOML is written beside it)")
    b.add_argument("--flange", default=None, metavar="LINK", help="flange link (default: tool0, panda_link8, "
                   "flange, or the child of the last revolute joint)")
    b.add_argument("--name", default=None, help="model name (default: the robot's)")
    b.add_argument("--f-low", type=float, default=9.0, metavar="HZ",
                   help="lowest natural frequency at the grid centre, motors locked (default 9)")
    b.add_argument("--spread", type=float, default=3.0,
                   help="highest of the arm's natural frequencies over the lowest, log-spaced (default 3)")
    b.add_argument("--zeta", type=float, default=0.03, help="damping ratio of each joint (default 0.03)")
    b.add_argument("--armature-ratio", type=float, default=0.3,
                   help="rotor inertia through the gearbox over the link-side inertia (default 0.3)")
    b.add_argument("--servo-ratio", type=float, default=20.0,
                   help="position-servo stiffness over joint stiffness (default 20)")
    b.add_argument("--spindle-kg", type=float, default=None,
                   help="spindle mass, kg (default 10 %% of the arm's moving mass)")
    b.add_argument("--spindle-hz", type=float, default=850.0,
                   help="lowest spindle mode with the dummy tool, Hz (default 850)")
    b.add_argument("--mount", choices=("inline", "bracket"), default="inline",
                   help="spindle on the last joint's axis (inline) or perpendicular to it on a bracket, "
                        "as on the milling robot")
    b.add_argument("--json", action="store_true", help="print a JSON summary")
    b.set_defaults(func=cmd_build)

    from rmbench.cli.calibrate import register_model_commands

    register_model_commands(msub)


def cmd_info(args) -> int:
    robot = load_robot(args)
    posture = resolve_posture(robot, args)
    op = robot.at(posture)
    bands = ("low", "high") if args.band == "both" else (args.band,)
    tables = [op.modes(b) for b in bands]
    if args.json:
        out = {"robot": robot.name, "tool": robot.tool, "spindle_rpm": robot.spindle_rpm,
               "posture": None if op.posture is None else
               {"x": op.posture.x, "y": op.posture.y, "theta": op.posture.theta},
               "q_cmd": op.q_cmd, "joints": list(robot.arm_joints),
               "s_1a": {b: robot.bands[b].s_1a for b in bands},
               "units": {"q_cmd": "rad", "posture": "m, m, rad", "f_n": "Hz", "zeta": "ratio",
                         "phiR": "s/kg", "phiL": "1 (normalised: phiL 1aY = 1)"},
               "modes": [m for t in tables for m in t.to_dict()]}
        print_json(out)
        return 0
    where = op.posture.label() + " (x mm, y mm, theta deg)" if op.posture else "joint command"
    print(f"{robot.name} with tool {robot.tool or 'none'}, posture {where}, spindle {robot.spindle_rpm:g} rpm")
    print("q_cmd (deg): " + ", ".join(f"{n} {math.degrees(q):.3f}" for n, q in zip(robot.arm_joints, op.q_cmd)))
    for t in tables:
        b = robot.bands[t.band]
        print(f"\n{t.band} band {b.f_min:g}-{b.f_max:g} Hz, point 1a {1000 * b.s_1a:g} mm up the tool; "
              "phi_R in s/kg, phi_L normalised to 1aY = 1")
        print(f"{'mode':>4} {'f_n Hz':>10} {'zeta %':>7}  " + "  ".join(f"{'phiR ' + c:>21}" for c in ("1X", "1Y", "1aX", "1aY")))
        for i in range(len(t)):
            vec = "  ".join(f"{_cx(t.phi_r[i, k]):>21}" for k in range(4))
            print(f"{i + 1:>4} {t.f_n[i]:10.3f} {100 * t.zeta[i]:7.3f}  {vec}")
        print(f"{'':>23}" + "  ".join(f"{'phiL ' + c:>21}" for c in ("1X", "1Y", "1aX", "1aY")))
        for i in range(len(t)):
            print(f"{i + 1:>4}{'':>19}" + "  ".join(f"{_cx(t.phi_l[i, k]):>21}" for k in range(4)))
    return 0


def cmd_variant(args) -> int:
    from rmbench.robot.load_stiffness import parse_load_stiffness
    from rmbench.robot.variant import make_variant

    robot = load_robot(args)
    masses = []
    for text in args.add_mass:
        parts = text.split(":")
        if len(parts) not in (2, 3):
            raise InputError(f"--add-mass must be WHERE:KG[:DX,DY,DZ], got {text!r}")
        try:
            mass = float(parts[1])
            offset = tuple(float(v) for v in parts[2].split(",")) if len(parts) == 3 else (0.0, 0.0, 0.0)
        except ValueError:
            raise InputError(f"--add-mass must be WHERE:KG[:DX,DY,DZ] with numbers, got {text!r}") from None
        if len(offset) != 3:
            raise InputError(f"--add-mass offset needs three numbers, got {text!r}")
        masses.append((parts[0], mass, offset))
    base = None
    if args.compliant_base:
        try:
            base = tuple(float(v) for v in args.compliant_base.split(","))
        except ValueError:
            raise InputError(f"--compliant-base must be K_LAT,K_TILT, got {args.compliant_base!r}") from None
        if len(base) != 2:
            raise InputError(f"--compliant-base must be K_LAT,K_TILT, got {args.compliant_base!r}")
    load = parse_load_stiffness(" ".join(args.load_stiffness), source="--load-stiffness")
    if not (args.edits or masses or base or load):
        raise InputError("nothing to change: give --set, --add-mass, --compliant-base or --load-stiffness")
    xml = make_variant(robot, args.edits, masses=masses, compliant_base=base, load_stiffness=load)
    out = Path(args.out)
    tmp = out.with_name(out.name + ".part")
    tmp.write_text(xml)
    tmp.replace(out)  # never leave a half-written model behind
    print(f"wrote {out} ({len(args.edits)} edits, {len(masses)} masses"
          f"{', compliant base' if base else ''}{', load-dependent stiffness' if load else ''}); "
          f"use it with --robot {out}")
    return 0


def cmd_build(args) -> int:
    from rmbench.robot.flexible_arm import FlexRule, SpindleRule, build_arm, campaign_toml

    rule = FlexRule(f_low=args.f_low, spread=args.spread, zeta=args.zeta, armature_ratio=args.armature_ratio,
                    servo_ratio=args.servo_ratio)
    spindle = SpindleRule(mass=args.spindle_kg, spindle_hz=args.spindle_hz, mount=args.mount)
    out = Path(args.out)
    if out.suffix.lower() != ".xml":
        raise InputError(f"--out must be an .xml file, got {args.out!r}")
    if not out.parent.is_dir():
        raise InputError(f"--out directory does not exist: {out.parent}")
    say = None if args.json else (lambda msg: print(msg, flush=True))
    built = build_arm(args.urdf, rule=rule, spindle=spindle, flange=args.flange, name=args.name, progress=say)
    toml_path = out.with_name(out.stem + "_campaign.toml")
    for path, text in ((out, built.xml), (toml_path, campaign_toml(built, out))):
        tmp = path.with_name(path.name + ".part")
        tmp.write_text(text)
        tmp.replace(path)  # never leave a half-written file behind
    g = built.grid
    summary = {"robot": built.arm.name, "urdf": str(built.arm.path), "out": str(out), "campaign": str(toml_path),
               "joints": list(built.arm.joints), "flange": built.arm.flange, "frozen": list(built.arm.frozen),
               "stiffness_nm_per_rad": built.stiffness, "damping_nms_per_rad": built.damping,
               "armature_kgm2": built.armature, "f_arm_hz": built.f_low, "f_spindle_hz": built.f_high,
               "bands_hz": list(built.bands), "table_z_mm": 1000 * g.table_z,
               "grid_x_mm": 1000 * g.x, "grid_y_mm": 1000 * g.y, "grid_theta_deg": np.degrees(g.theta),
               "validation": [p.label() for p in g.validation],
               "worst_limit_margin_deg": math.degrees(g.worst_margin), "worst_sigma_min": g.worst_sigma}
    if args.json:
        print_json(summary)
        return 0
    print(f"wrote {out}: {len(built.arm.joints)} flexible joints, arm modes "
          f"{', '.join(f'{f:.1f}' for f in built.f_low)} Hz, spindle modes "
          f"{', '.join(f'{f:.0f}' for f in built.f_high[:2])} Hz at the grid centre")
    print(f"posture grid: table {1000 * g.table_z:.0f} mm, x {1000 * g.x[0]:.0f}..{1000 * g.x[-1]:.0f} mm, "
          f"y {1000 * g.y[0]:.0f}..{1000 * g.y[-1]:.0f} mm, theta {np.degrees(g.theta[0]):.0f}.."
          f"{np.degrees(g.theta[-1]):.0f} deg; worst limit margin {math.degrees(g.worst_margin):.1f} deg")
    print(f"wrote {toml_path}: a campaign on this grid; use the robot with --robot {out}")
    return 0


def _cx(z: complex) -> str:
    return f"{z.real:+.4g}{z.imag:+.4g}i"


