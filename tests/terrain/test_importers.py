"""Importers on the shipped ROS and MovingAI maps, PGM reading, heightmap images and arrays."""

from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import label

from legplan.errors import SpecError
from legplan.terrain import build_map
from legplan.terrain.importers import import_heightmap, import_movingai, import_ros, read_grey_image

MAPS = Path(__file__).resolve().parents[2] / "maps"


def _connected(terrain, a, b):
    passable = terrain.costmap < terrain.nav_params.c_max
    labels, _ = label(passable)
    (ia, ja, _), (ib, jb, _) = terrain.grid.cell_of(np.array([a])), terrain.grid.cell_of(np.array([b]))
    return labels[ia[0], ja[0]] != 0 and labels[ia[0], ja[0]] == labels[ib[0], jb[0]]


def test_ros_warehouse():
    terrain = import_ros(MAPS / "ros" / "warehouse.yaml")
    assert terrain.grid.shape == (200, 200) and terrain.grid.resolution == 0.05
    assert terrain.grid.origin == pytest.approx((0.025, 0.025))
    points = np.array([[0.1, 5.0],     # outer wall
                       [2.0, 5.0],     # first rack (image columns 30-50)
                       [3.0, 5.0],     # aisle
                       [8.5, 5.0],     # passage through the last rack (image rows 96-104, y 4.8-5.2)
                       [9.5, 9.25],    # pillar: image rows 10-20 are near the top, i.e. large y
                       [9.4, 0.6]])    # unknown (grey) corner, treated as an obstacle
    occupied = terrain.occupancy[terrain.grid.cell_of(points)[:2]]
    assert occupied.tolist() == [True, True, False, False, True, True]
    assert _connected(terrain, (3.0, 2.0), (9.3, 5.0))


def test_pgm_p2_p5_and_16_bit_agree(tmp_path):
    pixels = np.array([[0, 128, 255], [10, 20, 30]], dtype=np.uint8)
    (tmp_path / "a.pgm").write_bytes(b"P5\n# c\n3 2\n255\n" + pixels.tobytes())
    (tmp_path / "b.pgm").write_text("P2\n3 2\n255\n" + " ".join(map(str, pixels.ravel())) + "\n")
    (tmp_path / "c.pgm").write_bytes(b"P5\n3 2\n65535\n" + (pixels.astype(">u2") * 257).tobytes())
    for name in "abc":
        assert np.allclose(read_grey_image(tmp_path / f"{name}.pgm"), pixels / 255)


@pytest.mark.parametrize("content, message", [
    (b"P5\n3 2\n255\n" + bytes(4), "truncated or corrupt image"),       # 4 of 6 pixels
    (b"P5\n3", "truncated or corrupt image"),                             # header cut
    (b"\x00garbage" * 10, "not a readable PGM/PNG image"),
])
def test_bad_pgm_is_one_line_naming_the_file(tmp_path, content, message):
    (tmp_path / "a.pgm").write_bytes(content)
    with pytest.raises(SpecError, match=message) as error:
        read_grey_image(tmp_path / "a.pgm")
    assert str(error.value).startswith(f"{tmp_path / 'a.pgm'}: ") and "\n" not in str(error.value)


def test_movingai_rooms():
    terrain = import_movingai(MAPS / "movingai" / "rooms.map", 0.1)
    assert terrain.grid.shape == (128, 128)
    # row 0 of the file (the top) is the outer wall at the largest y
    assert terrain.occupancy[-1].all() and terrain.occupancy[0].all()
    assert terrain.occupancy[127 - 32, 5]          # file row 32 (a wall row) is iy 95
    assert _connected(terrain, (1.5, 1.5), (11.3, 11.3))


def test_movingai_errors(tmp_path):
    bad = tmp_path / "bad.map"
    bad.write_text("type octile\nheight 2\nwidth 3\nmap\n..X\n...\n")
    with pytest.raises(SpecError, match="unknown cell characters"):
        import_movingai(bad, 1.0)
    bad.write_text("type octile\nheight 3\nwidth 3\nmap\n...\n...\n")
    with pytest.raises(SpecError, match="'map'"):
        import_movingai(bad, 1.0)


def test_heightmap_npy_and_png(tmp_path):
    array = np.zeros((20, 30))
    array[5:10, 10:20] = 0.4
    np.save(tmp_path / "h.npy", array)
    terrain = import_heightmap(tmp_path / "h.npy", 0.1, origin=(1.0, 2.0), scale=0.5)
    assert terrain.height_at(np.array([[2.5, 2.7], [1.0, 2.0]]), method="nearest") == pytest.approx(
        [0.2, 0.0])
    import matplotlib.image

    matplotlib.image.imsave(tmp_path / "h.png", np.flipud(array / 0.4), cmap="gray", vmin=0, vmax=1)
    image = import_heightmap(tmp_path / "h.png", 0.1, origin=(1.0, 2.0), scale=0.4)
    assert np.allclose(image.height, array, atol=0.01)


def test_nav_30m_queries_are_solvable():
    terrain = build_map(MAPS / "nav_30m.yaml")
    assert terrain.grid.shape == (600, 600)
    for start, goal in [((0.5, 0.5), (29.5, 29.5)), ((0.5, 29.5), (29.5, 0.5)),
                        ((6.0, 0.5), (24.0, 29.5)), ((0.5, 15.0), (29.5, 15.0))]:
        assert _connected(terrain, start, goal)
    assert 0.03 < terrain.occupancy.mean() < 0.3
