"""`legplan robot list|show`."""

import json

from click.testing import CliRunner
from robot_helpers import write_toy_robot

from legplan.cli.main import cli


def run(*args, env=None):
    return CliRunner().invoke(cli, [str(a) for a in args], env=env)


def test_robot_list():
    result = run("robot", "list")
    assert result.exit_code == 0, result.output
    assert "scarab2" in result.output and "24 DOF" in result.output and "jueying_mini" in result.output
    rows = {row["name"]: row for row in json.loads(run("robot", "list", "--json").output)}
    assert rows["scarab2"]["legs"] == 6 and rows["jueying_mini"]["navigation"] is True
    assert rows["anymal"]["centroidal"] is True and rows["scarab2"]["centroidal"] is False


def test_robot_list_searches_env_folders_first_and_lists_broken_folders(tmp_path):
    first, second = tmp_path / "first", tmp_path / "second"
    write_toy_robot(first / "toy")
    write_toy_robot(second / "toy", spec={"name": "shadowed"})       # same name later: not used
    write_toy_robot(second / "scarab2")                                # shadows the shipped scarab2
    (second / "nolegs").mkdir()
    write_toy_robot(second / "nolegs", spec={"name": "nolegs"})        # robot.yaml without legs
    (second / "draft").mkdir()
    (second / "draft" / "robot.urdf").write_text("<robot name='draft'/>")  # no robot.yaml yet
    env = {"LEGPLAN_ROBOTS": f"{first}:{second}"}
    result = run("robot", "list", "--json", env=env)
    assert result.exit_code == 0, result.output
    rows = {row["name"]: row for row in json.loads(result.output)}
    assert rows["toy"]["folder"] == str(first / "toy") and rows["toy"]["broken"] is None
    assert rows["scarab2"]["dof"] == 14                                # the toy, found before the shipped one
    assert rows["anymal"]["broken"] is None                            # shipped robots stay listed
    assert "field 'legs' is missing" in rows["nolegs"]["broken"]
    assert "robot.yaml: missing" in rows["draft"]["broken"]
    text = run("robot", "list", env=env)
    assert text.exit_code == 0
    assert f"robots in {first}, then {second}, then " in text.output
    assert [line.split()[1] for line in text.output.splitlines() if line.split()[0] == "draft"] == ["broken:"]
    assert run("robot", "show", "draft", env=env).exit_code == 2


def test_robot_show_text_json_and_png(tmp_path):
    png = tmp_path / "stance.png"
    result = run("robot", "show", "jueying_mini", "--png", png)
    assert result.exit_code == 0, result.output
    assert "18 DOF" in result.output and "alpha_max  0.52 rad/s^2" in result.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert run("robot", "show", "jueying_mini", "--png", png).exit_code == 2       # exists
    info = json.loads(run("robot", "show", "scarab2", "--json").output)
    assert (info["nv"], info["nq"], len(info["legs"]), len(info["joints"])) == (24, 25, 6, 18)
    assert info["navigation"] is None and len(info["spheres"]) == 28


def test_robot_show_by_path_and_errors(tmp_path):
    folder = tmp_path / "toy"
    write_toy_robot(folder)
    assert "toy: 14 DOF" in run("robot", "show", folder).output
    result = run("robot", "show", "no_such_robot")
    assert result.exit_code == 2 and "unknown robot" in result.stderr
    (folder / "robot.yaml").write_text("name: toy\n")
    result = run("robot", "show", folder / "robot.yaml")
    assert result.exit_code == 2 and "field 'legs' is missing" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_robot_show_centroidal(tmp_path):
    png = tmp_path / "anymal.png"
    result = run("robot", "show", "anymal", "--png", png)
    assert result.exit_code == 0, result.output
    assert "centroidal: 29.5 kg, base height 0.42 m, max normal force 1000 N, friction 0.5" in result.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    info = json.loads(run("robot", "show", "anymal", "--json").output)
    assert info["centroidal"]["nominal_feet"]["rh"] == [-0.34, -0.19, -0.42]
    assert info["centroidal"]["inertia"][0][1] == -0.000938112
    assert json.loads(run("robot", "show", "scarab2", "--json").output)["centroidal"] is None


def test_robot_check_exit_1_on_errors_and_json(tmp_path):
    from robot_helpers import toy_spec

    spec = toy_spec()
    spec["collision_spheres"][2]["offset"] = [0, 0, -0.14]       # shank spheres below the ground
    folder = tmp_path / "sunk"
    write_toy_robot(folder, spec)
    result = run("robot", "check", folder)
    assert result.exit_code == 1
    assert "error: sphere 2 (shank_a): " in result.output and "toy: 4 errors, 0 warnings" in result.output
    findings = json.loads(run("robot", "check", folder, "--json").output)
    assert {f["severity"] for f in findings} == {"error"} and len(findings) == 4
    assert run("robot", "check", "scarab2").exit_code == 0
