"""`legplan map build|import|show` end to end, and exit code 2 on bad input."""

from pathlib import Path

import numpy as np
from click.testing import CliRunner

from legplan.artefacts import open_artefact, read_summary
from legplan.cli.main import cli
from legplan.terrain import load_map
from pictures import drawn, pixels

MAPS = Path(__file__).resolve().parents[2] / "maps"


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def test_build_then_show(tmp_path):
    out, png = tmp_path / "map.h5", tmp_path / "map.png"
    result = _run("map", "build", MAPS / "single_pallet.yaml", "-o", out, "-q")
    assert result.exit_code == 0, result.output
    with open_artefact(out, kind="map") as f:
        assert f["terrain/height"].attrs["resolution"] == 0.01
        assert list(f["terrain/sdf"].attrs["origin"])[2] <= 0.0
        assert f["nav/costmap"].attrs["l1"] == 0.2
        assert read_summary(f)["height_max"][0] == 0.165
    assert load_map(out).height_at(np.array([[0.6, 0.0]]))[0] == 0.165
    result = _run("map", "show", out, "-o", png)
    assert result.exit_code == 0
    image = pixels(png)   # three filled panels: hill-shaded height, foothold mask, costmap
    assert drawn(image) > 0.3 and len(np.unique(image.reshape(-1, 3), axis=0)) > 500
    again = _run("map", "build", MAPS / "single_pallet.yaml", "-o", out)
    assert again.exit_code == 2 and "exists" in again.stderr


def test_bad_spec_exits_2_without_output(tmp_path):
    spec = tmp_path / "bad.yaml"
    spec.write_text("resolution: 0.05\nextent: {x: [0, 1], y: [0, 1]}\n"
                    "primitives: [{type: volcano}]\n")
    out = tmp_path / "map.h5"
    result = _run("map", "build", spec, "-o", out)
    assert result.exit_code == 2
    assert "primitives[0].type" in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not out.exists()
    assert _run("map", "build", tmp_path / "missing.yaml", "-o", out).exit_code == 2


def test_import_ros_movingai_heightmap(tmp_path):
    result = _run("map", "import", "ros", MAPS / "ros" / "warehouse.yaml", "-o", tmp_path / "w.h5")
    assert result.exit_code == 0, result.output
    assert load_map(tmp_path / "w.h5").grid.shape == (200, 200)
    missing = _run("map", "import", "movingai", MAPS / "movingai" / "rooms.map", "-o", tmp_path / "r.h5")
    assert missing.exit_code == 2 and "--resolution" in missing.stderr
    result = _run("map", "import", "movingai", MAPS / "movingai" / "rooms.map", "--resolution", "0.1",
                  "-o", tmp_path / "r.h5")
    assert result.exit_code == 0 and load_map(tmp_path / "r.h5").grid.resolution == 0.1
    np.save(tmp_path / "h.npy", np.full((10, 12), 2.0))
    result = _run("map", "import", "heightmap", tmp_path / "h.npy", "--resolution", "0.05",
                  "--origin", "1", "2", "--scale", "0.1", "-o", tmp_path / "h.h5")
    assert result.exit_code == 0, result.output
    terrain = load_map(tmp_path / "h.h5")
    assert terrain.grid.origin == (1.0, 2.0) and np.allclose(terrain.height, 0.2)


def test_producing_command_keeps_stdout_clean_and_quiet_silences_status(tmp_path):
    out = tmp_path / "map.h5"
    loud = _run("map", "build", MAPS / "single_pallet.yaml", "-o", out)
    assert loud.exit_code == 0 and loud.stdout == ""
    assert f"wrote {out}" in loud.stderr
    quiet = _run("map", "build", MAPS / "single_pallet.yaml", "-o", out, "--overwrite", "-q")
    assert quiet.exit_code == 0 and quiet.stdout == "" and quiet.stderr == ""
    again = _run("map", "show", out, "-o", tmp_path / "map.png")
    assert f"wrote {tmp_path / 'map.png'}" in again.stderr  # -q of the previous call does not linger
