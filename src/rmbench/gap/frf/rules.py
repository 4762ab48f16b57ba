"""The verdict rules of the FRF gap diagnosis: when a fitted effect explains the gap, when a
recalibration with a structural effect freed confirms it, and when a parameter's size lies inside
or beyond its ordinary spread. Each rule is one function; the thresholds come from the settings
(:class:`~rmbench.gap.frf.settings.DiagnosisSettings`) or are stated here with their reasons;
docs/design.md, "Verdict rules", lists every rule of both diagnoses once, with the test that
specifies it.

Vocabulary: the *held-out* χ² is the sum of squared normalised residuals (modes and FRFs, each
divided by its noise standard deviation) on the postures no fit saw; the *rms gap* is its square
root per residual; the *shrink* of a model against a baseline is ``1 − sqrt(χ²_model / χ²_base)``,
the share of the baseline's rms gap it closes. The *noise test*
(:func:`rmbench.gap.selection.significant`) asks whether a χ² and its largest residual are more
than the noise alone gives at level ``p_noise``. The *ordinary spread* of a parameter is its prior
range (±2σ of its group, :mod:`rmbench.robot.parameters`): what robots of one type differ by.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from rmbench.gap.selection import significant

__all__ = ["explains", "confirms", "beyond_spread", "within_spread", "spread_checked", "ordinary_total",
           "better_calibration"]

_Z95 = 1.96
"""Half-width of a two-sided 95 % normal interval, in standard deviations."""


def explains(best, nom, settings) -> bool:
    """Whether the search's best model ``best`` explains the gap of the nominal ``nom`` (both
    :class:`~rmbench.gap.frf.search.Fitted`).

    Two conditions, both on the held-out postures:

    * its residual is noise: the noise test at ``settings.p_noise`` (χ² and peak) passes, so what
      is left is what the sensors alone would leave;
    * it closed at least ``settings.min_shrink`` of the nominal's rms gap (0.5 by default): an
      effect that merely tidies up a gap already near the noise explains little of it, and on so
      small a gap any of several look-alikes passes the noise test.
    """
    if significant(best.chi2_held, best.n_held, p=settings.p_noise, peak=best.peak_held):
        return False
    shrink = 1 - np.sqrt(best.chi2_held / nom.chi2_held) if nom.chi2_held > 0 else 0.0
    return bool(shrink >= settings.min_shrink)


def confirms(c, null, *, gap: bool, pinned, first_chi2: float, min_shrink: float, nominal, groups) -> bool:
    """Whether the recalibration ``c`` with a structural effect freed explains the data, against
    the null recalibration ``null`` (no effect) and the first calibration's held-out χ²
    ``first_chi2`` (both :class:`~rmbench.gap.frf.confirm.Confirmed` for ``c`` and ``null``).

    Two rules, one per situation:

    * **The freed bound** (the effect behind an ordinary parameter the calibration left on a bound
      of its spread, ``pinned``): the candidate explains the data with less strain on the ordinary
      parameters (a lower training objective, data and prior), its held-out residual is noise, and
      its size lies beyond the spread with 95 % confidence (:func:`beyond_spread`). The held-out
      shrink is no measure here: a calibration pressed against the bound has already taken up the
      part of the effect that its ordinary parameter can mimic, so what is left lies just above the
      noise and even the true effect closes only part of it. The evidence is instead the strain
      the freed effect takes off the fit (data and prior) and a size no robot of the type reaches
      (e.g. a tool holder ×3.40: the null 1.37 times the noise test's threshold, the freed holder
      at the noise, a shrink of 46 %).
    * **Any other candidate**, only where the null leaves a gap (``gap``, and the null fails the
      noise test): held-out residual at the noise, at least ``min_shrink`` of the baseline's
      held-out rms gap closed (the baseline is the better of the null and the first calibration;
      an effect that tidies up a small gap is no explanation: a 2 % spindle change for a 40 g mass
      at the tool tip), and for a kind an ordinary group of ``groups`` also holds, a size outside
      that group's spread (:func:`within_spread`: inside it, it is an ordinary parameter).
    """
    if c.significant:
        return False
    if c.effect in pinned and c.train_objective < null.train_objective and beyond_spread(c, nominal, groups):
        return True
    if not gap:
        return False
    base_chi2 = min(null.chi2_held, first_chi2)
    # no gap is left to explain where the ordinary parameters alone reach the noise
    return bool(null.significant and base_chi2 > 0 and 1 - np.sqrt(c.chi2_held / base_chi2) >= min_shrink
                and not within_spread(c, nominal, groups))


def beyond_spread(c, nominal, groups) -> bool:
    """Whether some parameter the confirmed candidate ``c`` freed that is also an ordinary
    parameter of ``groups`` (of the robot ``nominal``) has its 95 % interval (±1.96 standard
    deviations of the recalibration's posterior) wholly outside that parameter's prior range:
    a size the ordinary spread of the robot type does not reach, with the data's uncertainty
    allowed for, so a structural fault rather than an unlucky ordinary robot."""
    from rmbench.robot.parameters import parameter_set

    _, ordinary = parameter_set(nominal, groups)
    bounds = {p.name: (p.lower, p.upper) for p in ordinary}
    names = [p.name for p in c.calibration.params]
    u = np.asarray(c.calibration.u, float)
    sd = np.sqrt(np.clip(np.diag(np.asarray(c.calibration.cov_u, float)), 0, None))
    for n in c.freed:
        if n in bounds:
            i = names.index(n)
            lo, hi = u[i] - _Z95 * sd[i], u[i] + _Z95 * sd[i]
            if lo > bounds[n][1] or hi < bounds[n][0]:
                return True
    return False


def within_spread(c, nominal, groups) -> bool:
    """Whether every parameter the confirmed candidate ``c`` freed that is also an ordinary
    parameter of ``groups`` ended inside that parameter's prior range (±2σ, its point value):
    then the candidate is an ordinary parameter the first calibration's prior held back, not a
    structural effect. False where no freed parameter is an ordinary one (a foundation's slide
    is structural at any size)."""
    from rmbench.robot.parameters import parameter_set

    _, ordinary = parameter_set(nominal, groups)
    bounds = {p.name: (p.lower, p.upper) for p in ordinary}
    u = dict(zip([p.name for p in c.calibration.params], np.asarray(c.calibration.u, float)))
    shared = [n for n in c.freed if n in bounds]
    return bool(shared) and all(bounds[n][0] <= u[n] <= bounds[n][1] for n in shared)


def spread_checked(dg, nominal, first):
    """The joint search's explanation ``dg`` (a :class:`~rmbench.gap.frf.result.Diagnosis`),
    unless every effect it chose is an ordinary parameter of the calibration (the tool holder, a
    link's mass) whose total size, the first calibration's ``first``
    (:class:`~rmbench.gap.frf.calibration.FirstCalibration`) and the effect's on top, ends inside
    its ordinary spread (:func:`ordinary_total`): then the calibration's prior merely held that
    parameter back, and the gap is no structural one ("no significant gap")."""
    from rmbench.robot.parameters import parameter_set

    cal = first.cal
    _, ordinary = parameter_set(nominal, first.settings.groups)
    bounds = {p.name: (p.lower, p.upper) for p in ordinary}
    cal_u = dict(zip([p.name for p in cal.params], np.asarray(cal.u, float)))
    chosen = [e for e in dg.effects if e.chosen]
    totals = [ordinary_total(e, cal_u, nominal) for e in chosen]
    if not chosen or any(t is None or not t or any(n not in bounds for n in t) for t in totals):
        return dg
    if not all(bounds[n][0] <= u <= bounds[n][1] for t in totals for n, u in t.items()):
        return dg
    names = ", ".join(e.name for e in chosen)
    note = (f"{names} closes the gap but stays within its ordinary spread (the calibration's prior held it "
            "back): an ordinary parameter, not a structural effect")
    return replace(dg, verdict="no significant gap", notes=dg.notes + (note,))


def ordinary_total(effect, cal_u: dict, nominal) -> dict | None:
    """``{parameter: u}`` of an effect (an :class:`~rmbench.gap.frf.result.EffectResult` of the
    calibrated model's library) on top of the first calibration's values ``cal_u``, for the kinds
    an ordinary group also holds (the tool holder's log stiffness factors add; a mass added to a
    body adds to its calibrated mass, read back as a log factor of the nominal ``nominal``'s);
    None for the other kinds."""
    if effect.kind == "tool_contact_stiffness":
        return {"tool_contact.translation": cal_u.get("tool_contact.translation", 0.0) + effect.params["ln_translation"],
                "tool_contact.rotation": cal_u.get("tool_contact.rotation", 0.0) + effect.params["ln_rotation"]}
    if effect.kind == "added_mass":
        name = f"{effect.location}.mass"
        m0 = float(nominal.model.body(effect.location).mass[0])
        m = m0 * np.exp(cal_u.get(name, 0.0)) + effect.params["mass"]
        return {name: float(np.log(max(m, 1e-9) / m0))}
    return None


def better_calibration(dg, null, first_chi2: float, notes: list) -> dict:
    """The fields of ``dg`` that report the null recalibration ``null`` as the calibration, where
    it is the better model without a structural effect (strictly lower held-out χ² than the first
    calibration's ``first_chi2``), with a note added to ``notes``; empty otherwise.

    The null continued the first calibration with the FRFs beside the modes; where the first had
    stopped short of the data (a local minimum of the modal residuals, a fit at its limit), the
    null's is the calibration the verdict rests on, and the one a user should take away."""
    if not null.chi2_held < first_chi2:
        return {}
    account = null.calibration.to_json()
    account["groups"] = list(dg.calibration["groups"])
    notes.append(f"the calibration reported is the recalibration with the FRFs, {null.rounds} round(s) from the "
                 f"first (held-out χ² {null.chi2_held:.4g} against {first_chi2:.4g} of the first)")
    return {"calibration": account, "calibrated_xml": null.calibration.xml}
