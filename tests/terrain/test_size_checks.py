"""One size check for all three axes of a map, made before anything large is read or allocated:
an SDF z-range is refused like absurd x/y sizes, and a heightmap's shape is read from its header."""

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from legplan.cli.main import cli
from legplan.errors import SpecError
from legplan.terrain.importers import npy_shape
from legplan.terrain.terrain_map import MAX_SDF_WORK, check_memory


def _run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.mark.parametrize("sdf, message", [
    ("{z_min: -1000, z_max: 1000}", "SDF too large to build: 20x20 cells x 40001 layers"),  # fits in memory
    ("{z_min: -100000, z_max: 100000}", "too large for memory"),
])
def test_map_build_refuses_an_absurd_sdf_z_range_naming_it(tmp_path, sdf, message):
    spec = tmp_path / "tall.yaml"
    spec.write_text(f"resolution: 0.05\nextent: {{x: [0, 1], y: [0, 1]}}\nsdf: {sdf}\n")
    result = _run("map", "build", spec, "-o", tmp_path / "map.h5")
    assert result.exit_code == 2
    line, = result.stderr.strip().splitlines()
    assert f"{spec}: field 'sdf.z_min/z_max'" in line and message in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tall.yaml"]


def test_the_work_limit_counts_layers_quadratically():
    check_memory((100, 100), 100, "m.yaml", "sdf")
    layers = int(np.sqrt(2 * MAX_SDF_WORK / 400)) + 1
    with pytest.raises(SpecError, match="m.yaml: field 'sdf' gives an SDF too large"):
        check_memory((20, 20), layers, "m.yaml", "sdf")


def _npy_header(path, shape):
    """A .npy file holding only the header of a float64 array of `shape`."""
    with open(path, "wb") as handle:
        np.lib.format.write_array_header_1_0(handle, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return path


def test_heightmap_npy_shape_is_refused_from_its_header(tmp_path):
    path = _npy_header(tmp_path / "huge.npy", (30000, 30000))  # a promise of 7 GB, and no data
    assert npy_shape(path) == (30000, 30000)
    result = _run("map", "import", "heightmap", path, "--resolution", "0.1", "-o", tmp_path / "h.h5")
    assert result.exit_code == 2
    assert "huge.npy: field 'resolution' gives a map too large for memory: 30000x30000" in result.stderr
    with pytest.raises(SpecError, match="cube.npy: heightmap must be a 2D numeric array, got shape"):
        npy_shape(_npy_header(tmp_path / "cube.npy", (3, 3, 3)))
    (tmp_path / "text.npy").write_text("not numpy")
    with pytest.raises(SpecError, match="text.npy: not a readable .npy array"):
        npy_shape(tmp_path / "text.npy")


def test_heightmap_image_size_is_refused_before_its_pixels_are_decoded(tmp_path):
    path = tmp_path / "big.png"
    Image.new("L", (9000, 9000)).save(path)
    path.write_bytes(path.read_bytes()[:200])  # the header survives, the pixel data does not
    result = _run("map", "import", "heightmap", path, "--resolution", "0.1", "-o", tmp_path / "h.h5")
    assert result.exit_code == 2
    assert "big.png: field 'resolution' gives a map too large for memory: 9000x9000" in result.stderr
