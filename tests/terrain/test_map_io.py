"""Map specs: shipped maps build; spec errors are one line naming file and field; save/load."""

from pathlib import Path

import numpy as np
import pytest

from legplan.errors import ArtefactError, SpecError
from legplan.terrain import build_map, load_map, save_map

MAPS = Path(__file__).resolve().parents[2] / "maps"


def _spec(tmp_path, text, name="spec.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


BASE = "resolution: 0.05\nextent: {x: [0, 1], y: [0, 1]}\n"


@pytest.mark.parametrize("body, field", [
    (BASE + "primitives: [{type: volcano, center: [0, 0]}]", "primitives[0].type"),
    ("resolution: -1\nextent: {x: [0, 1], y: [0, 1]}\n", "resolution"),
    ("resolution: 0.0001\nextent: {x: [0, 100], y: [0, 100]}\n", "resolution"),
    (BASE + "primitives: [{type: box, center: [0.5, 0.5], size: [0.2, 0.2], top: .nan}]",
     "primitives[0].top"),
    (BASE + "primitives: [{type: box, center: [0.5, 0.5], size: [0.2, -0.2], top: 1}]",
     "primitives[0].size"),
    (BASE + "primitives: [{type: gap, center: [0.5, 0.5], size: [0.2, 0.2]}]", "primitives[0].depth"),
    (BASE + "nav: {l1: 0.5, l2: 0.2}", "nav.l2"),
    (BASE + "nav: {radius: 0.5}", "nav.radius"),
    (BASE + "colour: red", "colour"),
    ("resolution: 0.05\nextent: {x: [1, 0], y: [0, 1]}\n", "extent.x"),
])
def test_spec_errors_name_file_and_field(tmp_path, body, field):
    path = _spec(tmp_path, body)
    with pytest.raises(SpecError) as info:
        build_map(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message and f"'{field}'" in message


def test_missing_spec_file(tmp_path):
    with pytest.raises(SpecError, match=r"absent.yaml: cannot read map spec \(No such file"):
        build_map(tmp_path / "absent.yaml")


def test_primitives_rasterize(tmp_path):
    path = _spec(tmp_path, BASE + """primitives:
  - {type: box, center: [0.25, 0.25], size: [0.2, 0.2], yaw: 0.3, height: 0.3}
  - {type: pillar, center: [0.75, 0.25], radius: 0.1, top: 0.5}
  - {type: polygon, vertices: [[0.6, 0.6], [0.9, 0.6], [0.75, 0.9]], top: 1.0, obstacle: true}
  - {type: slope, center: [0.25, 0.75], size: [0.4, 0.2], from: 0.0, to: 0.4}
  - {type: stairs, start: [0.0, 0.5], width: 0.1, steps: 3, rise: 0.1, run: 0.1}
""")
    terrain = build_map(path)
    at = terrain.height_at(np.array([[0.25, 0.25], [0.75, 0.25], [0.75, 0.7], [0.225, 0.75],
                                     [0.025, 0.5], [0.275, 0.5]]), method="nearest")
    assert np.allclose(at, [0.3, 0.5, 1.0, 0.175, 0.1, 0.3])
    assert terrain.occupancy[terrain.grid.cell_of(np.array([[0.75, 0.7]]))[:2]].all()


def test_save_load_round_trip(tmp_path):
    terrain = build_map(MAPS / "gap_crossing.yaml")
    out = tmp_path / "map.h5"
    save_map(terrain, out, inputs=[MAPS / "gap_crossing.yaml"])
    back = load_map(out)
    assert back.grid == terrain.grid and back.name == "gap_crossing"
    for name in ("height", "foothold", "occupancy", "distance", "costmap"):
        assert np.array_equal(getattr(back, name), getattr(terrain, name)), name
    assert np.array_equal(back.sdf.data, terrain.sdf.data)
    assert np.allclose(back.sdf.origin, terrain.sdf.origin)
    assert back.nav_params == terrain.nav_params and back.foothold_params == terrain.foothold_params
    with pytest.raises(ArtefactError, match="exists"):
        save_map(terrain, out)


def test_gap_crossing_geometry():
    terrain = build_map(MAPS / "gap_crossing.yaml")
    xy = np.array([[-0.6, 0.0], [0.6, 0.0], [0.0, 0.0], [0.0, 0.15], [0.0, -0.15], [0.0, 0.3]])
    assert np.allclose(terrain.height_at(xy, method="nearest"), [0, 0, -1, 0, 0, -1])
    assert terrain.is_foothold(xy).tolist() == [True, True, False, True, True, False]
    # a foot sphere beside the beam top edge is ~its diagonal distance away, not 1 m above the floor
    assert terrain.sdf.values(np.array([[0.0, 0.08, 0.04]]))[0] == pytest.approx(np.hypot(0.04, 0.04),
                                                                                 abs=0.01)
    assert terrain.sdf.data.nbytes < 100e6
