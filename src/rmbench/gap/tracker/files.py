"""A tracker diagnosis's folder: ``diagnosis.json``, ``sources.csv`` and ``pose_errors.png``
(:meth:`rmbench.gap.tracker.result.TrackerDiagnosis.save`)."""

from __future__ import annotations

from pathlib import Path

from rmbench.gap.jsonable import write_whole
from rmbench.io.strict_json import strict_dumps

__all__ = ["write_diagnosis"]


def write_diagnosis(dg, directory) -> dict:
    """Write a :class:`~rmbench.gap.tracker.result.TrackerDiagnosis` ``dg`` into ``directory``:
    ``diagnosis.json``, ``sources.csv`` and ``pose_errors.png``; their paths."""
    from rmbench.gap.plot import plot_pose_errors

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"json": out / "diagnosis.json", "csv": out / "sources.csv",
             "figure": out / "pose_errors.png"}
    write_whole(paths["json"], strict_dumps(dg.to_dict(), indent=1))
    rows = ["name,kind,location,chosen,share,confidence,heldout_rms_m,heldout_max_m,description"]
    for s in dg.sources:
        rows.append(f"{s.name},{s.kind},{s.location},{int(s.chosen)},{s.share:.4f},"
                    f"{s.confidence:.4f},{s.heldout_after['rms']:.6g},{s.heldout_after['max']:.6g},"
                    f"\"{s.description}\"")
    write_whole(paths["csv"], "\n".join(rows) + "\n")
    plot_pose_errors(dg, paths["figure"])
    return {k: str(v) for k, v in paths.items()}

