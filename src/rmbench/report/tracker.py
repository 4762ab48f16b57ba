"""Report section of a model-invalidation test on tracker readings (seed Fig. 7, interactive)."""

from __future__ import annotations

import numpy as np

from rmbench.report.page import Page

__all__ = ["invalidation_sections"]


def invalidation_sections(page: Page, result, *, scale: float = 1e3, unit: str = "mm") -> None:
    """Error magnitude of every measurement per location in the order explored, the location
    means, re-measured locations marked, and the accuracy level η tested.

    Parameters
    ----------
    result : InvalidationResult
    scale, unit : float, str
        Display factor and unit of the errors (m to mm by default).
    """
    mag = np.abs(result.measurements) if result.measurements.ndim == 1 else np.linalg.norm(result.measurements, axis=1)
    order = list(dict.fromkeys(result.index.tolist()))          # locations in the order first measured
    rank = {j: k + 1 for k, j in enumerate(order)}
    x = np.array([rank[j] for j in result.index], float)
    again = np.isin(result.index, result.remeasured)
    mean = np.linalg.norm(np.atleast_2d(result.mean.T).T[order], axis=1)
    sec = page.section(f"Model invalidation: {result.verdict}",
                       f"H0: |e| ≤ η = {scale * result.eta:.4g} {unit} at every location; P* = {result.p_star:.4f} "
                       f"(α = {result.alpha}); {result.n_measurements} measurements at {len(order)} locations, "
                       f"stopped: {result.stop}.")
    sec.figure({"data": [
        {"type": "scatter", "mode": "markers", "x": x[~again], "y": scale * mag[~again], "name": "measured once",
         "marker": {"color": "#1f77b4", "size": 6}},
        {"type": "scatter", "mode": "markers", "x": x[again], "y": scale * mag[again], "name": "re-measured location",
         "marker": {"color": "#d62728", "symbol": "x", "size": 8}},
        {"type": "scatter", "mode": "markers", "x": np.arange(1, len(order) + 1, dtype=float), "y": scale * mean,
         "name": "location mean", "marker": {"color": "black", "symbol": "line-ew-open", "size": 14}}],
        "layout": {"height": 420, "xaxis": {"title": {"text": "location (order explored)"}},
                   "yaxis": {"title": {"text": f"error magnitude ({unit})"}, "rangemode": "tozero"},
                   "shapes": [{"type": "line", "xref": "paper", "x0": 0, "x1": 1, "y0": scale * result.eta,
                               "y1": scale * result.eta, "line": {"color": "#2ca02c", "width": 2}}]}},
        caption=f"Green line: η = {scale * result.eta:.4g} {unit}.")
