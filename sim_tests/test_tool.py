"""The lumped Timoshenko tool: statics exact, first bending mode near the continuous beam's."""

import math

import mujoco
import numpy as np
import pytest
from _written_numbers import written_differences

from rmbench.robot.beam import cantilever_frequencies
from rmbench.robot.catalog import models_dir
from rmbench.robot.linear import equilibrium, linearize
from rmbench.robot.tool import TOOLS, tool_xml


def _clamped_tool(name, rigid_contact=True):
    """The tool alone, clamped at the holder face (contact joints locked if rigid_contact)."""
    spec = mujoco.MjSpec.from_string(tool_xml(TOOLS[name]))
    spec.option.gravity = [0, 0, 0]
    if rigid_contact:  # contact slides locked; the root hinges keep only the root bending
        c1 = TOOLS[name].hinge_layout()[0]
        for j in spec.joints:
            if j.name in ("contact_x", "contact_y"):
                j.stiffness = [1e15, 0, 0]
            elif j.name in ("contact_rx", "contact_ry"):
                j.stiffness = [1 / c1, 0, 0]
    model = spec.compile()
    data = mujoco.MjData(model)
    equilibrium(model, data, np.array([], int))
    return model, data, linearize(model, data)


@pytest.mark.parametrize("name", sorted(TOOLS))
def test_bundled_tool_files_match_their_generator(name):
    # numbers to their written digits: see _written_numbers
    assert written_differences((models_dir() / "tools" / f"{name}.xml").read_text(), tool_xml(TOOLS[name])) == []


@pytest.mark.parametrize("name", sorted(TOOLS))
def test_lumped_tool_tip_compliance_equals_timoshenko_cantilever(name):
    # the hinge layout reproduces L³/3EI + L/κGA exactly (static condensation is exact)
    model, data, lin = _clamped_tool(name)
    jac = np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, jac, None, model.site("tip").id)
    compliance = jac[0] @ np.linalg.solve(lin.K, jac[0])
    assert compliance == pytest.approx(TOOLS[name].static_tip_compliance(), rel=1e-6)


def test_reference_tool_first_bending_mode_near_7_khz():
    # Euler-Bernoulli gives 6.8 kHz for the Ø20 x 50 mm carbide cantilever; Timoshenko theory
    # (shear, rotary inertia; 60-element FE) 6.3 kHz. Two rigid segments with exact statics
    # resolve the first mode to better than 10 %.
    tool = TOOLS["dummy"]
    _, _, lin = _clamped_tool("dummy")
    f1 = lin.modes().f_n.min()
    nu = tool.poisson
    f_timoshenko = cantilever_frequencies(
        tool.overhang, E=tool.youngs_modulus, G=tool.youngs_modulus / (2 * (1 + nu)),
        kappa=6 * (1 + nu) / (7 + 6 * nu), rho=tool.density, diameter=tool.diameter)[0]
    rho_a = tool.density * math.pi * tool.diameter**2 / 4
    f_eb = 1.875**2 / (2 * math.pi) * math.sqrt(tool.ei / (rho_a * tool.overhang**4))
    assert f_timoshenko < f_eb
    assert f1 == pytest.approx(f_timoshenko, rel=0.10)


def test_timoshenko_elements_reach_euler_bernoulli_for_a_slender_beam():
    # L/d = 100: shear and rotary inertia change f1 by < 0.01 %
    e, d, length, rho = 2.1e11, 0.01, 1.0, 7800.0
    f1 = cantilever_frequencies(length, E=e, G=e / 2.6, kappa=0.9, rho=rho, diameter=d)[0]
    f_eb = 1.875**2 / (2 * math.pi) * math.sqrt(e * d**2 / 16 / (rho * length**4))  # EI/ρA = E d²/16
    assert f1 == pytest.approx(f_eb, rel=1e-4)


def test_target_tool_is_more_compliant_than_reference():
    assert TOOLS["endmill"].static_tip_compliance() > TOOLS["dummy"].static_tip_compliance()
