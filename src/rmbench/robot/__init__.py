"""Virtual robots: MJCF models, postures, inverse kinematics and exact linear ground truth.

The public API::

    robot = Robot.load("irb6660", tool="dummy")
    op = robot.at(Posture.from_mm_deg(1800, -200, 0))
    op.modes("low"), op.modes("high"), op.frf(freq)
"""

from rmbench.robot.catalog import robot_names, tool_names
from rmbench.robot.linear import ComplexModes, LinearModel
from rmbench.robot.model import COORDS, Band, OperatingPoint, Robot
from rmbench.robot.modes import PARAMS, ModeTable
from rmbench.robot.posture import Posture, parse_posture, seed_grid, validation_postures
from rmbench.robot.tool import TOOLS, ToolGeometry

__all__ = ["Robot", "OperatingPoint", "Band", "COORDS", "Posture", "parse_posture", "seed_grid",
           "validation_postures", "LinearModel", "ComplexModes", "ModeTable", "PARAMS",
           "ToolGeometry", "TOOLS", "robot_names", "tool_names"]
