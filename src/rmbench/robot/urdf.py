"""Reading an arm's URDF: where it comes from, which chain is the arm, and whether it can be one.

A URDF is parsed as XML (never evaluated) and checked before MuJoCo sees it, so that a file the
bench cannot use gets one line naming the problem: a link with two parents (a closed loop), no
revolute joint between the root and the flange (a prismatic-only or fixed-only chain), a prismatic
joint on the arm, or a moving link without an ``<inertial>``.

Arms by name come from example-robot-data (``example_robot_data`` of the package
``example-robot-data-loaders``): ``ur10``, ``panda`` and the others it lists.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from rmbench.errors import ModelError

__all__ = ["UrdfArm", "find_urdf", "read_urdf", "urdf_spec", "example_robot_names"]

# The flange (tool flange, z out of the face) of the arms whose URDF names it; others default to the
# child link of the last revolute joint. The Panda's panda_hand and tcp sit behind a 45° turn.
_FLANGES = {"tool0", "panda_link8", "flange", "link_eef", "gripperMover"}
_REVOLUTE = ("revolute", "continuous")


@dataclass(frozen=True)
class UrdfArm:
    """The arm found in a URDF.

    Attributes
    ----------
    path : Path
        The URDF file.
    name : str
        Robot name (the example-robot-data name, or the file's stem).
    joints : tuple of str
        Revolute joints from the root to the flange, in order (the arm's axes).
    flange : str
        Link that carries the spindle: its +z axis points out of the tool flange.
    frozen : tuple of str
        Moving joints off the arm (fingers): held rigid at their zero position.
    mass : float
        Total mass of the links moved by the arm's joints, kg.
    """

    path: Path
    name: str
    joints: tuple[str, ...]
    flange: str
    frozen: tuple[str, ...]
    mass: float

    def pin_configuration(self, model, q) -> np.ndarray:
        """Configuration of pinocchio's own model of this URDF (``pin.buildModelFromUrdf``) with
        the arm's joints at ``q`` (rad, shape (n_joints,), in ``joints`` order) and every other
        joint at its neutral position, shape (model.nq,)."""
        import pinocchio as pin

        qu = pin.neutral(model)
        for name, value in zip(self.joints, q):
            qu[model.joints[model.getJointId(name)].idx_q] = value
        return qu


def example_robot_names() -> list[str]:
    """Names example-robot-data can load (empty if the package is missing)."""
    try:
        from example_robot_data.robots_loader import ROBOTS
    except ImportError:
        return []
    return sorted(ROBOTS)


def find_urdf(source: str | os.PathLike) -> tuple[Path, str]:
    """The URDF file and robot name of an example-robot-data name or a URDF path.

    Raises
    ------
    ModelError
        For a missing file or a name example-robot-data does not know.
    """
    text = str(source)
    path = Path(text)
    if path.suffix.lower() == ".urdf" or path.parent != Path("."):
        if not path.is_file():
            raise ModelError(f"URDF file not found: {path}")
        return path, path.stem
    names = example_robot_names()
    if not names:
        raise ModelError("robot names need example-robot-data: pip install example-robot-data-loaders "
                         "(or give a URDF path)")
    if text not in names:
        arms = [n for n in names if n.split("_")[0] in ("ur3", "ur5", "ur10", "panda", "kinova", "xarm7", "z1",
                                                         "so100", "so101", "iiwa")]
        raise ModelError(f"unknown example-robot-data robot {text!r}; arms it has: {', '.join(arms)} "
                         "(or give a URDF path)")
    from example_robot_data.robots_loader import loader

    try:
        urdf = Path(os.path.realpath(loader(text).df_path))
    except Exception as err:  # noqa: BLE001 - a loader failing on its own data is the user's to see
        raise ModelError(f"example-robot-data cannot load {text!r}: {err}") from None
    base = text.split("_")[0]
    if base.startswith("ur") and base not in urdf.name:
        # example-robot-data-loaders 5.0.0 maps "ur3" to the UR5's URDF
        raise ModelError(f"example-robot-data gives {urdf.name} for {text!r}, another arm's URDF; "
                         "give the URDF file's path instead")
    return urdf, text


def read_urdf(path: Path, name: str, *, flange: str | None = None) -> UrdfArm:
    """Parse and check a URDF; find the arm's chain from the root link to the flange.

    Parameters
    ----------
    path : Path
    name : str
    flange : str, optional
        Flange link. By default a link named like a tool flange (``tool0``, ``panda_link8``,
        ``flange``) on the chain, else the child link of the chain's last revolute joint.
    """
    links, joints, parent_of, children, root_link = _parse_tree(path)

    def chain_to(link):
        return _chain_to(link, parent_of, joints)

    if flange is None:
        flange = _default_flange(links, joints, chain_to)
    elif flange not in links:
        raise ModelError(f"URDF has no link {flange!r} for the flange; links: {', '.join(list(links)[:12])}")
    chain = chain_to(flange)
    arm = [j for j in chain if joints[j][0] in _REVOLUTE]
    bad = [j for j in chain if joints[j][0] not in (*_REVOLUTE, "fixed")]
    if not arm:
        kinds = sorted({joints[j][0] for j in chain}) or ["none"]
        raise ModelError(f"URDF chain from {root_link!r} to {flange!r} has no revolute joint (joint types: "
                         f"{', '.join(kinds)}); the bench needs a revolute arm")
    if bad:
        raise ModelError(f"URDF arm joint {bad[0]!r} is {joints[bad[0]][0]}; only revolute and fixed joints "
                         "are supported between the base and the flange")
    moving = _moving_links(arm, joints, children)
    _check_inertias(arm, joints, links)
    frozen = tuple(j for j, (kind, _, child, _) in joints.items()
                   if kind != "fixed" and j not in arm and child in moving)
    if any(joints[j][3].find("mimic") is not None and j not in frozen for j in arm):
        raise ModelError("URDF arm joints with <mimic> are not supported")
    return UrdfArm(path=path, name=name, joints=tuple(arm), flange=flange, frozen=frozen,
                   mass=float(sum(_mass(links[n]) or 0.0 for n in moving)))


def _parse_tree(path: Path):
    """The URDF's links by name, joints by name ``(type, parent, child, element)``, each child
    link's joint, each link's child joints and the root link; a tree, else a ``ModelError``."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as err:
        raise ModelError(f"malformed URDF {path}: {err}") from None
    if root.tag != "robot":
        raise ModelError(f"{path} is not a URDF: its root element is <{root.tag}>, not <robot>")
    links = {ln.get("name"): ln for ln in root.findall("link")}
    if not links:
        raise ModelError(f"URDF {path} has no links")
    joints = {}
    parent_of: dict[str, str] = {}
    children: dict[str, list[str]] = {n: [] for n in links}
    for j in root.findall("joint"):
        jn, kind = j.get("name"), j.get("type")
        p, c = j.find("parent"), j.find("child")
        if p is None or c is None or p.get("link") not in links or c.get("link") not in links:
            raise ModelError(f"URDF joint {jn!r} names a parent or child link that does not exist")
        child = c.get("link")
        if child in parent_of:
            raise ModelError(f"URDF has a closed loop: link {child!r} is the child of joints {parent_of[child]!r} "
                             f"and {jn!r}; the bench needs a serial arm (a kinematic tree)")
        parent_of[child] = jn
        joints[jn] = (kind, p.get("link"), child, j)
        children[p.get("link")].append(jn)
    roots = [n for n in links if n not in parent_of]
    if len(roots) != 1:
        raise ModelError(f"URDF has {len(roots)} root links ({', '.join(roots[:4])}); a closed loop or "
                         "disconnected links")
    return links, joints, parent_of, children, roots[0]


def _chain_to(link: str, parent_of: dict, joints: dict) -> list[str]:
    """The joints from the root link to ``link``, in order."""
    out = []
    while link in parent_of:
        out.append(parent_of[link])
        link = joints[parent_of[link]][1]
    return out[::-1]


def _default_flange(links: dict, joints: dict, chain_to) -> str:
    """A link named like a tool flange, else the child of the last revolute joint on the chain
    with the most revolute joints."""
    named = [n for n in links if n in _FLANGES]
    if named:
        return named[0]
    deepest = max(links, key=lambda n: sum(joints[j][0] in _REVOLUTE for j in chain_to(n)))
    last = [j for j in chain_to(deepest) if joints[j][0] in _REVOLUTE]
    return joints[last[-1]][2] if last else deepest


def _moving_links(arm: list, joints: dict, children: dict) -> set:
    """Every link that an arm joint moves (its child and all below)."""
    moving = set()
    for j in arm:
        stack = [joints[j][2]]
        while stack:
            link = stack.pop()
            moving.add(link)
            stack += [joints[c][2] for c in children[link]]
    return moving


def _check_inertias(arm: list, joints: dict, links: dict) -> None:
    """Each arm joint's child link has a positive mass and an inertia tensor."""
    for j in arm:
        link = links[joints[j][2]]
        mass = _mass(link)
        if mass is None or mass <= 0:
            raise ModelError(f"URDF link {joints[j][2]!r} (moved by joint {j!r}) has no <inertial> mass; "
                             "the bench needs the inertia of every moving link")
        if _inertia(link) is None:
            raise ModelError(f"URDF link {joints[j][2]!r} has no <inertia>; the bench needs the inertia "
                             "of every moving link")


def _mass(link) -> float | None:
    m = link.find("inertial/mass")
    if m is None:
        return None
    try:
        value = float(m.get("value"))
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


def _inertia(link):
    i = link.find("inertial/inertia")
    if i is None:
        return None
    try:
        return [float(i.get(k)) for k in ("ixx", "iyy", "izz")]
    except (TypeError, ValueError):
        return None


def urdf_spec(arm: UrdfArm) -> mujoco.MjSpec:
    """MuJoCo's own URDF import, kinematics and inertias only (meshes dropped).

    The collision meshes are ``package://`` paths MuJoCo cannot open and the visual ones COLLADA it
    cannot decode; the bench needs neither. Static links are kept as bodies (``fusestatic`` off,
    set before the first compile, which would otherwise remove them), so the flange survives.
    """
    try:
        spec = mujoco.MjSpec.from_file(str(arm.path))
    except ValueError as err:
        raise ModelError(f"MuJoCo cannot read URDF {arm.path}: {str(err).strip().splitlines()[0]}") from None
    spec.compiler.fusestatic = False
    for g in list(spec.geoms):
        if g.type == mujoco.mjtGeom.mjGEOM_MESH:
            spec.delete(g)
    for m in list(spec.meshes):
        spec.delete(m)
    return spec
