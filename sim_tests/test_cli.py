"""The command line: numbers as tables or JSON, bad input as one line and exit code 2."""

import json

import pytest

from rmbench.cli import main


def test_model_info_json(cli):
    code, out, _ = cli("model", "info", "--robot", "irb6660", "--tool", "dummy",
                       "--posture", "1800,-200,0", "--json")
    assert code == 0
    data = json.loads(out)
    assert len(data["q_cmd"]) == 6
    assert len(data["modes"]) >= 9
    mode = data["modes"][0]
    assert set(mode) >= {"f_n", "zeta", "phiL", "phiR"}
    assert mode["phiL"]["1aY"][0] == pytest.approx(1.0)


def test_model_info_table(cli):
    code, out, _ = cli("model", "info", "--posture", "1800,200,60", "--band", "high")
    assert code == 0
    assert "high band" in out and "f_n Hz" in out


def test_model_variant_writes_a_loadable_file(cli, tmp_path):
    path = tmp_path / "v.xml"
    code, out, _ = cli("model", "variant", "--robot", "irb6660", "--set", "j2_flex.stiffness*=0.8",
                       "--out", str(path))
    assert code == 0 and path.is_file()
    code, out, _ = cli("model", "info", "--robot", str(path), "--json")
    assert code == 0 and json.loads(out)["tool"] == "dummy"


def test_model_variant_load_stiffness_and_servo_options(cli, tmp_path):
    path = tmp_path / "v.xml"
    code, _, _ = cli("model", "variant", "--robot", "irb6660", "--load-stiffness", "j2_flex:0.2,j3_flex:0.1",
                     "--set", "a2.kp*=0.8", "--out", str(path))
    assert code == 0
    from rmbench.robot import Robot

    robot = Robot.load(path)
    assert robot.load_stiffness == {"j2_flex": 0.2, "j3_flex": 0.1}
    assert robot.model.actuator("a2").gainprm[0] == pytest.approx(0.8 * 8e7)


def _malformed(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text("<mujoco><worldbody><body><joint type='hinge'/></body></mujoco>")
    return str(path)


@pytest.mark.parametrize("argv, message", [
    (["model", "info", "--robot", "kuka"], "unknown robot 'kuka'"),
    (["model", "info", "--tool", "drill"], "unknown tool 'drill'"),
    (["model", "info", "--posture", "3500,0,0"], "unreachable"),
    (["model", "info", "--posture", "18OO,0"], "posture must be numbers"),
    (["model", "variant", "--set", "nosite.pos=0,0,1", "--out", "x.xml"], "no joint, body or site named 'nosite'"),
    (["model", "variant", "--set", "a9.kp*=2", "--out", "x.xml"], "no actuator named 'a9'"),
    (["model", "variant", "--load-stiffness", "j9:0.2", "--out", "x.xml"], "no joint 'j9'"),
    (["model", "variant", "--load-stiffness", "j2_flex=0.2", "--out", "x.xml"], "must be JOINT:ALPHA"),
    (["model", "info", "--robot", "MALFORMED"], "malformed MJCF"),
    (["model", "info", "--robot", "missing/robot.xml"], "not found"),
], ids=["unknown-robot", "unknown-tool", "unreachable", "bad-posture", "unknown-site", "unknown-actuator",
        "load-stiffness-unknown-joint", "load-stiffness-malformed", "malformed-mjcf", "missing-file"])
def test_bad_input_gives_one_line_and_exit_2(cli, tmp_path, argv, message):
    argv = [_malformed(tmp_path) if a == "MALFORMED" else a for a in argv]
    code, out, err = cli(*argv)
    assert code == 2
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


def test_unknown_option_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["model", "info", "--frobnicate"])
    assert exc.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


@pytest.mark.parametrize("command", ["model", "campaign", "modal", "tracker", "invalidate", "control"])
def test_command_without_subcommand_prints_its_help_and_exits_2(cli, command):
    code, out, _ = cli(command)
    assert code == 2
    assert out.startswith(f"usage: rmbench {command} ") and "SUBCOMMAND" in out
