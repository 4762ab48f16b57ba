"""Whether a drawn effect can be seen in a campaign, decided without the method it is scored on.

The exact as-tested FRFs of the real robot with and without the effect (the impact campaign's
linear method with its noise off: the same postures, commanded by the nominal robot, the same
sensors and hammer), their difference judged against the campaign's own noise on an independent
noise draw:

    χ²_with = Σ |H_with − H_without + N₁|² / σ̂²,    χ²_null = Σ |N₂|² / σ̂²

over every posture, spectral line and FRF entry. N₁ and N₂ are two independent draws of the
campaign's noise (noisy runs of the robot without the effect minus its noise-free run, other
seeds), and σ̂² is the noise's variance per posture, line and output estimated from a third draw,
averaged over the inputs and ±``SMOOTH`` lines. Without the effect χ²_with and χ²_null are two
independent sums of n terms of mean near 1 (each the square modulus of a complex Gaussian over an
estimate of its variance): their difference has mean 0 and standard deviation √(2n), whatever bias
the estimate σ̂² carries, which scales both alike. The effect is *visible* where χ²_with − χ²_null
exceeds z·√(2n), z the standard normal's ``1 − p`` quantile (p = 1e-3, the diagnosis's own
noise-test level: the bench asks what a noise test could see at best). Sizes are never enlarged:
an invisible draw is counted and reported apart.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
from scipy.stats import norm

__all__ = ["SMOOTH", "P_VISIBLE", "campaign_toml", "frfs", "visibility"]

SMOOTH = 5            # lines either side over which the noise's variance is averaged
P_VISIBLE = 1e-3      # the level of the visibility test


def campaign_toml(robot_path: str, postures, seed: int, *, noise_scale: float, rpm: float = 0.0) -> str:
    """A linear campaign's TOML: the calibration bench's bands, commanded by the nominal IRB6660, the
    spindle at ``rpm`` rev/min."""
    from rmbench.impact import load_config

    base = load_config("seed_full")
    rows = ", ".join(f"[{1e3 * p.x:.6g}, {1e3 * p.y:.6g}, {np.degrees(p.theta):.6g}]" for p in postures)
    lines = ['name = "visibility"', f"seed = {seed}", 'method = "linear"', f"noise_scale = {noise_scale:g}",
             "[robot]", f'name = "{robot_path}"', 'commands_from = "irb6660"']
    if rpm:
        lines.append(f"spindle_rpm = {rpm:.6g}")
    lines += ["[grid]", 'kind = "list"', f"postures = [{rows}]"]
    for band, b in base.bands.items():
        lines += [f"[bands.{band}]", f"f_min = {b.f_min}", f"f_max = {b.f_max}", f'sensor = "{b.sensor}"',
                  f"s_1a_mm = {b.s_1a_mm}", f"sample_rate = {b.sample_rate}", f"line_spacing = {b.line_spacing}",
                  f"[bands.{band}.hammer]", f"pulse_ms = {b.hammer.pulse_ms}", f"peak_n = {b.hammer.peak_n}"]
    return "\n".join(lines) + "\n"


def frfs(xml: str, postures, seed: int, *, noise_scale: float, workers: int = 1, rpm: float = 0.0):
    """The as-tested receptances of the robot ``xml`` at the postures, its spindle at ``rpm``:
    ``H`` (over posture, freq, out, inp; m/N), exact where ``noise_scale`` is 0, with its
    ``band`` per line."""
    from rmbench.impact import open_campaign, parse_config, run_campaign

    tmp = Path(tempfile.mkdtemp(prefix="rmbench_vis_"))
    try:
        (tmp / "robot.xml").write_text(xml)
        toml = campaign_toml(str(tmp / "robot.xml"), postures, seed, noise_scale=noise_scale, rpm=rpm)
        run_campaign(parse_config(toml), tmp / "c.nc", toml=toml, workers=workers, progress=False)
        ds = open_campaign(tmp / "c.nc")
        if "ok" in ds.coords and not ds.ok.values.all():
            raise RuntimeError("the real robot could not hold a posture")
        return ds[["H"]].load()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _variance(noise: np.ndarray) -> np.ndarray:
    """σ² per posture, line and output from one noise draw (n_posture, n_freq, 4, 4): |N|²
    averaged over the inputs and ±:data:`SMOOTH` lines, broadcast back to every entry."""
    p = np.mean(np.abs(noise) ** 2, axis=3)                        # (posture, freq, out)
    kernel = np.ones(2 * SMOOTH + 1)
    num = np.apply_along_axis(lambda v: np.convolve(v, kernel, mode="same"), 1, p)
    den = np.convolve(np.ones(p.shape[1]), kernel, mode="same")[None, :, None]
    return (num / den)[..., None] * np.ones((1, 1, 1, noise.shape[3]))


def visibility(xml_without: str, xml_with: str, postures, seed: int, *, p: float = P_VISIBLE,
               workers: int = 1, rpm_with: float = 0.0, signals=None) -> dict:
    """Whether the change from ``xml_without`` to ``xml_with`` shows beyond the campaign's noise.

    ``rpm_with``: the spindle's speed with the change (a spinning spindle); ``signals``: a map of
    the measured FRF dataset with the change (a turned sensor's, ``truth.structural.turned_signals``).

    Returns ``{"chi2_with": χ²_with, "chi2_null": χ²_null, "n": terms, "threshold": z·√(2n),
    "visible": bool, "effect_chi2": the noise-free part Σ |ΔH|²/σ̂²}``.
    """
    h0 = frfs(xml_without, postures, seed, noise_scale=0.0, workers=workers).H.values
    with_ = frfs(xml_with, postures, seed, noise_scale=0.0, workers=workers, rpm=rpm_with)
    h1 = (with_ if signals is None else signals(with_)).H.values
    draws = [frfs(xml_without, postures, seed + k, noise_scale=1.0, workers=workers).H.values - h0
             for k in (7919, 104729, 1299709)]
    var = _variance(draws[0])
    ok = var > 0
    chi2_with = float(np.sum(np.abs((h1 - h0 + draws[1])[ok]) ** 2 / var[ok]))
    chi2_null = float(np.sum(np.abs(draws[2][ok]) ** 2 / var[ok]))
    effect = float(np.sum(np.abs((h1 - h0)[ok]) ** 2 / var[ok]))
    n = int(np.count_nonzero(ok))
    threshold = float(norm.ppf(1 - p) * np.sqrt(2 * n))
    return {"chi2_with": chi2_with, "chi2_null": chi2_null, "n": n, "threshold": threshold,
            "visible": bool(chi2_with - chi2_null > threshold), "effect_chi2": effect}
