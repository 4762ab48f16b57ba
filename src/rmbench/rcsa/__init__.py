"""Receptance coupling substructure analysis (METHODS.md §3, §4, §6; issue 16).

Tool change (seed 000): the full tip receptance of the reference tool — from the measured 4x4
matrix by finite differences (:func:`full_receptance`), or its translations at 1 and 1a coupled
through the tool's beam model — is decoupled from the reference tool's free-free Timoshenko
overhang and recoupled to the target tool's, with a complex contact stiffness and cross terms kept;
the target contact can be identified from one posture where both tools were measured::

    from rmbench.rcsa import change_tool, campaign_receptance, identify_contact
    from rmbench.robot.tool import TOOLS
    t_ref = campaign_receptance(ds, index=1, band="high")         # (freq, 4, 4), 1X 1rX 1Y 1rY
    pred = change_tool(t_ref.values, t_ref.freq.values, TOOLS["dummy"], TOOLS["endmill"])
    pred.tip                                                     # (freq, 2, 2) m/N

Robot-supported part (seed 001): :func:`couple_part` (Eqs. 6, 12-14) from the part's FRFs and the
robot's direct FRF at the joint, checked by :func:`spatial_coupling` (Eq. 18); the simulated scene
is :func:`rmbench.robot.part.support_scene`.
"""

from rmbench.rcsa.contact import Contact
from rmbench.rcsa.coupling import (MAX_CONDITION, IllConditionedWarning, ToolChange, change_tool,
                                   couple_tool, holder_receptance, scaled_condition)
from rmbench.rcsa.identify import ContactFit, identify_contact
from rmbench.rcsa.part import PartCoupling, amplitude_reduction, couple_part, spatial_coupling
from rmbench.rcsa.receptance import FULL_COORDS, POINT_COORDS, campaign_receptance, full_receptance
from rmbench.rcsa.substructure import TOOL_MODELS, ToolReceptance, shank_mass_matrix, tool_receptance

__all__ = ["Contact", "ToolChange", "IllConditionedWarning", "change_tool", "couple_tool",
           "holder_receptance", "scaled_condition", "MAX_CONDITION", "ContactFit", "identify_contact",
           "FULL_COORDS", "POINT_COORDS", "campaign_receptance", "full_receptance", "ToolReceptance",
           "tool_receptance", "TOOL_MODELS", "shank_mass_matrix", "couple_part", "spatial_coupling",
           "amplitude_reduction", "PartCoupling"]
