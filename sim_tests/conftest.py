"""Shared fixtures: the bundled robots at a few operating points (built once per session)."""

import pytest

from rmbench.robot import Posture, Robot


@pytest.fixture(scope="session")
def irb():
    return Robot.load("irb6660", tool="dummy")


@pytest.fixture(scope="session")
def irb_op(irb):
    """The IRB6660 stand-in at the seed's first validation posture."""
    return irb.at(Posture.from_mm_deg(1800, -200, 0))


@pytest.fixture(scope="session")
def mh180():
    return Robot.load("mh180")
