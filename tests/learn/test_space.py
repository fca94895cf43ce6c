"""Task-space files: every field checked with a one-line error naming file and field; seeded sampling."""

from pathlib import Path

import numpy as np
import pytest

from legplan.dyn.terrain import TerrainModel
from legplan.errors import SpecError
from legplan.learn.space import read_space, sample_tasks, task_vector
from legplan.robots import load_robot
from legplan.terrain import build_map

ROOT = Path(__file__).resolve().parents[2]
TINY = ROOT / "tests" / "data" / "learn_flat_trot.yaml"
GOOD = TINY.read_text().replace("../../maps/flat.yaml", f"{ROOT}/maps/flat.yaml")


def write(tmp_path, text, name="space.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("space", sorted((ROOT / "tasks").glob("*.yaml")), ids=lambda p: p.stem)
def test_shipped_task_spaces_load(space):
    loaded = read_space(space)
    assert loaded.gait in ("walk", "trot") and Path(loaded.map).is_file()


@pytest.mark.parametrize("old, new, field", [
    ("gait: trot", "gait: gallop", "gait"),
    ("strides: 2", "strides: 0", "strides"),
    ("duration: 1.2", "duration: -1", "duration"),
    ("costs: none", "costs: nosuch", "costs"),
    ("yaw: [-0.2, 0.2]}", "yaw: [0.2, -0.2]}", "start.yaw"),
    ("y: [-0.15, 0.15]", "y: [-0.15, .nan]", "start.y[1]"),
    ("goal: {x: 0.0,", "goal: {z: 1, x: 0.0,", "goal.z"),
    ("costs: none", "costs: none\nspeed: 3", "speed"),
    (f"map: {ROOT}/maps/flat.yaml", "map: nowhere.yaml", "map"),
])
def test_bad_field_is_a_one_line_error_naming_file_and_field(tmp_path, old, new, field):
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new))
    with pytest.raises(SpecError) as info:
        read_space(path)
    message = str(info.value)
    assert message.startswith(str(path)) and f"field '{field}'" in message and "\n" not in message


def test_sampling_is_seeded_and_inside_the_ranges(tmp_path):
    space = read_space(write(tmp_path, GOOD))
    model = load_robot("anymal").centroidal
    terrain = TerrainModel(build_map(space.map))
    a = sample_tasks(space, 5, np.random.default_rng(3), model, terrain)
    b = sample_tasks(space, 5, np.random.default_rng(3), model, terrain)
    c = sample_tasks(space, 5, np.random.default_rng(4), model, terrain)
    assert a == b and a != c
    starts = np.array([t.start for t in a])
    assert np.all((starts[:, 0] >= -0.6) & (starts[:, 0] <= -0.3)) and np.all(np.abs(starts[:, 2]) <= 0.2)
    assert all(t.goal == (0.0, 0.0, 0.0) and t.gait == "trot" and t.strides == 2 for t in a)


def test_task_vector_is_the_start_in_the_goal_frame():
    x = task_vector((1.0, 1.0, 0.1), (1.0, 0.0, np.pi / 2))
    assert np.allclose(x, [1.0, 0.0, 0.1 - np.pi / 2, 1.0, 0.0, np.pi / 2])


def test_an_init_knows_its_map_by_content_not_by_how_the_path_was_written(tmp_path, monkeypatch):
    from legplan.learn.network import check_space

    monkeypatch.chdir(ROOT)
    relative = read_space(Path("tasks") / "single_pallet_walk.yaml").record()
    absolute = read_space(ROOT / "tasks" / "single_pallet_walk.yaml").record()
    assert relative["map"] != absolute["map"]
    check_space("init.h5", relative, absolute)  # the same map file: accepted
    other = dict(absolute, map_sha256="0" * 64)  # same name, other content
    with pytest.raises(SpecError, match="field 'space.map'"):
        check_space("init.h5", relative, other)
    legacy = {k: v for k, v in relative.items() if k != "map_sha256"}  # an init.h5 from before the hash
    check_space("init.h5", legacy, absolute)
    with pytest.raises(SpecError, match="field 'space.map'"):
        check_space("init.h5", legacy, dict(absolute, map=str(ROOT / "maps" / "double_pallet.yaml")))
