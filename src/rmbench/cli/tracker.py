"""``rmbench tracker`` and ``rmbench invalidate`` (laser-tracker campaigns, model invalidation)."""

from __future__ import annotations

__all__ = ["register"]


def register(sub) -> None:
    """Register the tracker commands (filled in by the tracker stage)."""
