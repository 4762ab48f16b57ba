"""Where the bundled robots and tools live, and how names and paths resolve to MJCF files."""

from __future__ import annotations

from pathlib import Path

from rmbench.errors import ModelError

__all__ = ["models_dir", "robot_names", "tool_names", "resolve_robot", "resolve_tool"]


def models_dir() -> Path:
    """The directory of bundled MJCF files (``models/mjcf`` of the repository or the wheel)."""
    here = Path(__file__).resolve()
    for candidate in (here.parents[1] / "models" / "mjcf", here.parents[3] / "models" / "mjcf"):
        if (candidate / "irb6660.xml").is_file():
            return candidate
    raise ModelError("bundled models not found: reinstall rmbench (models/mjcf is missing)")


def robot_names() -> list[str]:
    """Names of the bundled robots."""
    return sorted(p.stem for p in models_dir().glob("*.xml"))


def tool_names() -> list[str]:
    """Names of the bundled tools."""
    return sorted(p.stem for p in (models_dir() / "tools").glob("*.xml"))


def _resolve(what: str, value: str | Path, directory: Path, names: list[str]) -> Path:
    path = Path(value)
    if path.suffix.lower() == ".xml" or path.parent != Path("."):
        if not path.is_file():
            raise ModelError(f"{what} file not found: {path}")
        return path
    if str(value) not in names:
        raise ModelError(f"unknown {what} {str(value)!r}; bundled: {', '.join(names)} (or a path to an MJCF file)")
    return directory / f"{value}.xml"


def resolve_robot(robot: str | Path) -> Path:
    """MJCF path of a bundled robot name, or the given path after checking it exists."""
    return _resolve("robot", robot, models_dir(), robot_names())


def resolve_tool(tool: str | Path) -> Path:
    """MJCF path of a bundled tool name, or the given path after checking it exists."""
    return _resolve("tool", tool, models_dir() / "tools", tool_names())
