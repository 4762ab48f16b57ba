"""Building and editing robot specifications (mujoco.MjSpec).

All model edits go through MjSpec, never through hand-copied XML. The assembled robot is written
to MJCF text once, and both MuJoCo and pinocchio are built from that same text, so the two agree
to the last written digit.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import mujoco
import numpy as np

from rmbench.errors import ModelError

__all__ = ["load_spec", "graft_tool", "copy_body", "move_body", "spec_to_xml", "custom_numeric", "custom_text",
           "set_custom_text", "TOOL_PREFIX"]

TOOL_PREFIX = "tool_"


def load_spec(path: Path) -> mujoco.MjSpec:
    """Parse an MJCF file into a spec; a malformed file raises :class:`ModelError`."""
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        spec.compile()
    except (ValueError, mujoco.FatalError) as err:
        msg = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise ModelError(f"malformed MJCF {path}: {msg}") from None
    return spec


def spec_to_xml(spec: mujoco.MjSpec) -> str:
    """MJCF text of a spec (warnings of the XML writer are not the user's concern)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return spec.to_xml()


def custom_numeric(spec: mujoco.MjSpec, name: str, default=None) -> np.ndarray | None:
    """Value of a ``<custom><numeric>`` field, or ``default`` when absent."""
    for numeric in spec.numerics:
        if numeric.name == name:
            return np.asarray(numeric.data, float)
    return None if default is None else np.asarray(default, float)


def custom_text(spec: mujoco.MjSpec, name: str) -> str | None:
    """Value of a ``<custom><text>`` field, or None when absent."""
    for text in spec.texts:
        if text.name == name:
            return text.data
    return None


def set_custom_text(spec: mujoco.MjSpec, name: str, value: str) -> None:
    """Set a ``<custom><text>`` field, adding it when absent."""
    for text in spec.texts:
        if text.name == name:
            text.data = value
            return
    spec.add_text(name=name, data=value)


def graft_tool(spec: mujoco.MjSpec, tool: mujoco.MjSpec, site: str = "tool_mount") -> None:
    """Copy a tool's ``root`` body into ``spec`` at ``site``, names prefixed with ``tool_``.

    MjSpec's own ``attach`` wraps the tool in a ``<frame>``, which pinocchio's MJCF reader skips;
    a plain copy keeps one model source readable by both.
    """
    try:
        mount = spec.site(site)
    except KeyError:
        mount = None
    if mount is None:
        raise ModelError(f"the robot has no site {site!r} to mount a tool on")
    root = tool.body("root")
    if root is None:
        raise ModelError("the tool MJCF has no body named 'root'")
    if any(b.name.startswith(TOOL_PREFIX) for b in spec.bodies):
        raise ModelError("the robot already carries a tool; load it without --tool")
    copy_body(root, mount.parent, TOOL_PREFIX, pos=np.array(mount.pos), quat=np.array(mount.quat))


def copy_body(src, parent, prefix: str = "", pos=None, quat=None, *, strip: str = "") -> None:
    """Copy a body subtree (inertials, hinge/slide joints, geoms, sites) under ``parent``.

    New names are ``prefix + name`` with the suffix ``strip`` removed (to move a subtree whose
    original names were first set aside).
    """
    def name(element):
        return prefix + (element.name.removesuffix(strip) if strip else element.name)

    body = parent.add_body(name=name(src),
                           pos=src.pos if pos is None else pos,
                           quat=src.quat if quat is None else quat)
    body.mass = src.mass
    body.ipos = src.ipos
    body.iquat = src.iquat
    body.inertia = src.inertia
    body.explicitinertial = src.explicitinertial
    for j in src.joints:
        body.add_joint(name=name(j), type=j.type, axis=j.axis, pos=j.pos,
                       stiffness=j.stiffness, damping=j.damping, armature=j.armature,
                       springref=j.springref, range=j.range, limited=j.limited)
    for g in src.geoms:
        body.add_geom(name=name(g) if g.name else "", type=g.type, size=g.size, pos=g.pos, quat=g.quat, rgba=g.rgba,
                      fromto=g.fromto, contype=0, conaffinity=0, group=g.group, mass=0)
    for s in src.sites:
        body.add_site(name=name(s), pos=s.pos, quat=s.quat, size=s.size, rgba=s.rgba)
    for child in src.bodies:
        copy_body(child, body, prefix, strip=strip)


def move_body(spec: mujoco.MjSpec, body, parent, pos=None) -> None:
    """Give ``body`` of ``spec`` (and all it carries) the new parent ``parent``, at ``pos`` in it
    (default: its own pos, unchanged); its elements keep their names, and actuators keep their
    joints. An ``MjSpec`` cannot reparent a body: its elements' names are first set aside, the
    subtree copied (:func:`copy_body`) and the original deleted."""
    old = "__moved"
    for element in _subtree(body):
        if element.name:
            element.name += old
    copy_body(body, parent, strip=old, pos=pos)
    spec.delete(body)


def _subtree(body):
    """The body, its joints, geoms and sites, and those of all its descendants."""
    yield body
    yield from body.joints
    yield from body.geoms
    yield from body.sites
    for child in body.bodies:
        yield from _subtree(child)
