"""Which structural candidates a calibrated diagnosis confirms by recalibration: the best of each
confirmable kind the search refined (:func:`confirm_picks`), the effects behind the ordinary
parameters the calibration left on a bound of their spread (:func:`pinned`), and the sizes a
sensor candidate is confirmed at (:func:`fitted_sizes`)."""

from __future__ import annotations

import numpy as np

__all__ = ["confirm_picks", "fitted_sizes", "pinned"]


def confirm_picks(models, lib: dict, n: int) -> list:
    """The candidates to confirm: the best-scored refined single of each confirmable kind (the
    tool holder, the spindle bearings, the foundation, a body's mass, a sensor's placement), then
    the kinds no refined single stands for (not a sensor, confirmed from its fitted size, nor a
    spinning spindle), at most ``n``, and the foundation always.

    One per kind rather than the best few overall: after a calibration has moved the ordinary
    parameters to mimic a structural effect, the first-order search can rank that effect below
    the others (a sliding foundation's sway is what the first joints' stiffness and the base's
    tilt mimic best), and the recalibration is what can tell them apart. The foundation is the
    effect the ordinary parameters mimic most completely (the base group's tilt and the links'
    centres of mass take a slide up, so that little of its signature is left on the calibrated
    model), so it is confirmed even when others fill the quota (e.g. a foundation sliding
    94 µm/kN ranked fifth)."""
    from rmbench.gap.frf.confirm import DESIGN_KINDS, confirmable

    best = {}
    for m in models:
        if len(m["params"]) != 1:
            continue
        name, = m["params"]
        effect = lib.get(name)
        if effect is None or not confirmable(effect):
            continue
        if effect.kind not in best or m["score"] < best[effect.kind][0]:
            best[effect.kind] = (m["score"], effect)
    picks = [e for _, e in sorted(best.values(), key=lambda x: x[0])]
    for effect in lib.values():
        # a sensor is confirmed from its fitted size, and a spinning spindle only where the search
        # saw it: only a refined one
        if (confirmable(effect) and effect.kind not in ("added_mass", "non_reciprocity") + DESIGN_KINDS
                and effect.kind not in best):
            best[effect.kind] = (np.inf, effect)
            picks.append(effect)
    out = picks[:n]
    out += [e for e in picks[n:] if e.kind == "base_compliance"]
    return out


def fitted_sizes(models) -> dict:
    """``{effect name: values}`` of every refined single (the size a sensor candidate is
    confirmed at), in the effect's units."""
    return {name: np.array(list(values.values()), float)
            for m in models if len(m["params"]) == 1 for name, values in m["params"].items()}


def pinned(cal, lib: dict) -> list:
    """The confirmable effects behind the ordinary parameters the calibration ``cal`` left on a
    bound of their prior range, in the calibration's parameter order. The range is the spread of
    robots of the type (±2σ); a robot inside it calibrates to values inside it, so a value pressed
    onto the edge says the data ask for more than the spread allows (robots of the spread alone
    left none there: 0 of 20 on two bench seeds)."""
    out = []
    for p in cal.params:
        # a parameter whose nominal is its bound (a rigid foundation) rests there by default
        effect = lib.get(_pinned_effect(p.name)) if p.on_bound and not np.isclose(p.value, p.nominal) else None
        if effect is not None and effect not in out:
            out.append(effect)
    return out


# ordinary parameters that stand for a confirmable structural effect when they end on a bound of
# their spread: a link's mass (a mass added to it), the tool holder, the foundation
def _pinned_effect(name: str) -> str | None:
    if name.endswith(".mass"):
        return f"added_mass@{name[:-len('.mass')]}"
    if name.startswith("tool_contact."):
        return "tool_contact_stiffness@tool_contact"
    if name.startswith("base."):
        return "base_compliance@base"
    return None
