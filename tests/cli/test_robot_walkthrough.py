"""The bring-your-own-robot walk-through of docs/robots.md on tests/data/hexapod.urdf (no foot
frames): robot init -> robot check -> steps generate on flat ground -> step plan; and the PNG."""

from pathlib import Path

import numpy as np
from click.testing import CliRunner
from PIL import Image

from legplan.artefacts import open_artefact, read_summary
from legplan.cli.main import cli

HEXAPOD = Path(__file__).parents[1] / "data" / "hexapod.urdf"
FLAT = """name: flat
resolution: 0.02
extent: {x: [-0.6, 0.6], y: [-0.5, 0.5]}
ground: 0.0
primitives: []
"""


def run(*args, env=None):
    result = CliRunner().invoke(cli, [str(a) for a in args], env=env)
    return result


def test_hexapod_walkthrough(tmp_path):
    robots = tmp_path / "robots"
    env = {"LEGPLAN_ROBOTS": str(robots)}
    result = run("robot", "init", HEXAPOD, "-o", robots / "phantomx")
    assert result.exit_code == 0, result.stderr
    assert (robots / "phantomx" / "robot.yaml").is_file()
    again = run("robot", "init", HEXAPOD, "-o", robots / "phantomx")
    assert again.exit_code == 2 and "output exists" in again.stderr
    check = run("robot", "check", "phantomx", env=env)
    assert check.exit_code == 0, check.output
    assert "phantomx: 0 errors" in check.output
    (tmp_path / "flat.yaml").write_text(FLAT)
    assert run("map", "build", tmp_path / "flat.yaml", "-o", tmp_path / "map.h5", "-q").exit_code == 0
    steps = tmp_path / "steps.h5"
    result = run("steps", "generate", tmp_path / "map.h5", "--robot", "phantomx", "--start", "-0.05", "0", "0",
                 "--goal", "0.05", "0", "0", "-o", steps, "-q", env=env)
    assert result.exit_code == 0, result.stderr
    motion = tmp_path / "motion.h5"
    result = run("step", "plan", tmp_path / "map.h5", steps, "-o", motion, "-q", env=env)
    assert result.exit_code == 0, result.stderr
    with open_artefact(motion) as handle:
        summary = read_summary(handle)
    assert summary["steps_planned"][0] >= 4
    assert summary["steps_succeeded"][0] == summary["steps_planned"][0]
    png = tmp_path / "phantomx.png"
    assert run("robot", "show", "phantomx", "--png", png, env=env).exit_code == 0
    pixels = np.asarray(Image.open(png).convert("RGB")).astype(int)
    magenta = (pixels[..., 0] > 200) & (pixels[..., 1] < 80) & (pixels[..., 2] > 200)
    assert magenta.sum() > 200                          # the joint axes are drawn


def test_robot_init_bad_urdf_is_one_line_exit_2(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'></robot>")
    result = run("robot", "init", bad, "-o", tmp_path / "out")
    assert result.exit_code == 2 and str(bad) in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out" / "robot.yaml").exists()
