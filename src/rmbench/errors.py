"""Package exceptions: every user-facing problem is an :class:`RmbenchError`.

The CLI prints such errors as one line and exits with code 2; anything else is a bug.
"""

__all__ = ["RmbenchError", "ModelError", "UnreachablePosture", "InputError"]


class RmbenchError(ValueError):
    """A problem with what the user asked for (bad input, unknown name, unreachable posture)."""


class ModelError(RmbenchError):
    """A robot, tool or MJCF file that cannot be used: unknown name, malformed file, missing site."""


class UnreachablePosture(RmbenchError):
    """A posture that inverse kinematics cannot reach within the joint limits."""


class InputError(RmbenchError):
    """Malformed user input: a posture string, a variant edit, a config value."""
