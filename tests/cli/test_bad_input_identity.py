"""Artefacts that do not belong together, and NaN (issue 35 class 4): the one artefact reader refuses a
non-finite value in any float dataset of any kind (but where NaN means "none") for every command,
and an artefact paired with a map other than the one it was made on is refused where they meet."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from bad_input_support import assert_refused, few, invoke, mutated, with_value
from hypothesis import given
from hypothesis import strategies as st

from legplan.artefacts.identity import check_same_map
from legplan.artefacts.schema import NAN_MEANS_NONE
from legplan.errors import ArtefactError

ROOT = Path(__file__).parents[2]


@pytest.fixture(scope="module")
def more(inputs, tmp_path_factory):
    """The kinds `inputs` lacks: sim.h5 (its traj executed), dataset.h5 and init.h5 (the tiny flat
    trot space), and other.h5, a map with other heights on the same grid."""
    tmp = tmp_path_factory.mktemp("more")
    space = tmp / "space.yaml"
    space.write_text((ROOT / "tests" / "data" / "learn_flat_trot.yaml").read_text()
                     .replace("../../maps/flat.yaml", str(ROOT / "maps" / "flat.yaml")))
    other = tmp / "other.yaml"
    other.write_text("name: other\nresolution: 0.02\nextent: {x: [-1, 1], y: [-1, 1]}\n"
                     "primitives: [{type: box, center: [0.6, 0.6], size: [0.2, 0.2], height: 0.05}]\n")
    paths = {"space": space, "sim": tmp / "sim.h5", "dataset": tmp / "dataset.h5", "init": tmp / "init.h5",
             "other": tmp / "other.h5", "flat": tmp / "flat.h5"}
    for args in (["dyn", "simulate", inputs["traj"], inputs["map"], "-o", paths["sim"]],
                 ["learn", "dataset", space, "--n", "3", "--iterations", "10", "-o", paths["dataset"]],
                 ["learn", "train", paths["dataset"], "--hidden", "4,4", "-o", paths["init"]],
                 ["map", "build", other, "-o", paths["other"]],
                 ["map", "build", ROOT / "maps" / "flat.yaml", "-o", paths["flat"]]):
        result = invoke([*args, "-q"])
        assert result.exit_code in (0, 1), result.stderr  # a simulated fall is exit 1, still an artefact
    return {**inputs, **paths}


# A command that reads all of an artefact of each kind; {bad} the broken file.
READERS = {
    "map": ["map", "show", "{bad}", "-o", "{out}.png"],
    "steps": ["steps", "export", "{bad}", "-o", "{out}.csv"],
    "motion": ["step", "show", "{bad}", "--map", "{map}", "-o", "{out}.png"],
    "nav": ["nav", "show", "{bad}", "--map", "{map}", "-o", "{out}.png"],
    "traj": ["dyn", "show", "{bad}", "-o", "{out}.png"],
    "sim": ["compare", "{bad}", "{sim}"],
    "dataset": ["learn", "train", "{bad}", "-o", "{out}.h5"],
    "init": ["dyn", "plan", "{flat}", "--start", "-0.4", "0", "0", "--goal", "0", "0", "0", "--strides", "2",
             "--duration", "1.2", "--init", "{bad}", "-o", "{out}.h5"],
}


def _checked_datasets(path: Path, kind: str) -> list[str]:
    """The float datasets the reader must keep finite (not excused by `NAN_MEANS_NONE`)."""
    import fnmatch

    names = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, node: names.append(name) if isinstance(node, h5py.Dataset)
                     and node.dtype.kind == "f" and node.size else None)
    return [n for n in names if not any(fnmatch.fnmatchcase(n, p) for p in NAN_MEANS_NONE.get(kind, {}))]


@few(30)
@given(data=st.data())
def test_a_non_finite_value_in_any_artefact_is_refused_by_the_one_reader(more, tmp_path_factory, data):
    kind = data.draw(st.sampled_from(sorted(READERS)))
    name = data.draw(st.sampled_from(_checked_datasets(more[kind], kind)))
    index = data.draw(st.integers(min_value=0))
    value = data.draw(st.sampled_from([np.nan, np.inf, -np.inf]))
    tmp_path = tmp_path_factory.mktemp("nan")
    bad = mutated(more[kind], tmp_path / f"bad_{kind}.h5", name, with_value(index, value))
    values = {**{k: str(v) for k, v in more.items()}, "bad": str(bad), "out": str(tmp_path / "out")}
    args = [part.format(**values) for part in READERS[kind]]
    out = Path(args[args.index("-o") + 1]) if "-o" in args else None
    assert_refused(invoke(args), bad.name, f"'/{name}' holds NaN or inf", output=out)


def test_report_and_learn_train_refuse_nan_in_one_line(more, tmp_path):
    traj = mutated(more["traj"], tmp_path / "nan_traj.h5", "tasks/0000/samples/base_pos", with_value(5, np.nan))
    sim = mutated(more["sim"], tmp_path / "nan_sim.h5", "tasks/0000/series/base_pos", with_value(5, np.nan))
    for bad in (traj, sim):
        assert_refused(invoke(["report", bad, "-o", tmp_path / "report"]), bad.name, "holds NaN",
                       output=tmp_path / "report")
    with h5py.File(more["dataset"], "r") as f:
        converged = int(np.flatnonzero(f["success"][()])[0])
    bad = mutated(more["dataset"], tmp_path / "nan_cost.h5", "cost", with_value(converged, np.nan))
    assert_refused(invoke(["learn", "train", bad, "-o", tmp_path / "init.h5"]), "nan_cost.h5", "'/cost' holds NaN",
                   output=tmp_path / "init.h5")


def test_nan_where_it_means_none_is_read(more, tmp_path):
    # a dataset's task that did not converge: its outcome rows may be NaN
    bad = tmp_path / "failed.h5"
    shutil.copy(more["dataset"], bad)
    with h5py.File(bad, "r+") as f:
        success = f["success"][()]
        success[0] = False
        f["success"][...] = success
        cost = f["cost"][()]
        cost[0] = np.nan
        f["cost"][...] = cost
    result = invoke(["inspect", bad])
    assert result.exit_code == 0, result.stderr


# Pairs: an artefact made on map.h5 given another map.
PAIRS = {
    "dyn simulate": (["dyn", "simulate", "{traj}", "{other}", "-o", "{out}.h5"], "traj.h5", "planned on"),
    "step plan": (["step", "plan", "{other}", "{steps}", "--steps", "0", "-o", "{out}.h5"], "steps.h5", "made on"),
    "baseline step": (["baseline", "step", "{other}", "{steps}", "--steps", "0", "-o", "{out}.h5"], "steps.h5",
                      "made on"),
    "nav refine": (["nav", "refine", "{other}", "{nav}", "-o", "{out}.h5"], "nav.h5", "searched on"),
    "nav show": (["nav", "show", "{nav}", "--map", "{other}", "-o", "{out}.png"], "nav.h5", "searched on"),
    "step show": (["step", "show", "{motion}", "--map", "{other}", "-o", "{out}.png"], "motion.h5", "planned on"),
    "steps show": (["steps", "show", "{steps}", "--map", "{other}", "-o", "{out}.png"], "steps.h5", "made on"),
    "dyn plan --init": (["dyn", "plan", "{other}", "--start", "-0.4", "0", "0", "--goal", "0", "0", "0", "--strides",
                         "2", "--duration", "1.2", "--init", "{init}", "-o", "{out}.h5"], "init.h5", "trained on"),
}


@pytest.mark.parametrize("pair", sorted(PAIRS))
def test_an_artefact_on_another_map_is_refused_where_they_meet(more, tmp_path, pair):
    template, named, said = PAIRS[pair]
    values = {**{k: str(v) for k, v in more.items()}, "out": str(tmp_path / "out")}
    args = [part.format(**values) for part in template]
    out = Path(args[args.index("-o") + 1])
    assert_refused(invoke(args), named, said, "other.h5", output=out)


def test_the_same_terrain_built_again_is_the_same_map(more, tmp_path):
    from legplan.artefacts import input_record

    built = []
    for name in ("a", "b"):  # two files that differ (name, time), one terrain
        spec = tmp_path / f"{name}.yaml"
        spec.write_text(f"name: {name}\nresolution: 0.05\nextent: {{x: [-1, 1], y: [-1, 1]}}\n")
        built.append(tmp_path / f"{name}.h5")
        assert invoke(["map", "build", spec, "-o", built[-1], "-q"]).exit_code == 0
    assert built[0].read_bytes() != built[1].read_bytes()
    check_same_map(more["traj"], built[1], [input_record(built[0])])
    with pytest.raises(ArtefactError, match="another terrain"):
        check_same_map(more["traj"], more["other"], [input_record(built[0])])
    result = invoke(["dyn", "plan", more["flat"], "--start", "-0.4", "0", "0", "--goal", "0", "0", "0", "--strides",
                     "2", "--duration", "1.2", "--init", more["init"], "-o", tmp_path / "t.h5", "-q"])
    assert result.exit_code in (0, 1), result.stderr  # the map built from the space's spec is its map


def test_learn_cycle_refuses_bad_weights_before_any_solve(more, tmp_path):
    weights = tmp_path / "w.yaml"
    weights.write_text("base_lin: -1.0\n")
    out = tmp_path / "cycle"
    result = invoke(["learn", "cycle", more["space"], "--n", "2", "--cycles", "1", "--weights", weights, "-o", out])
    assert_refused(result, "w.yaml", "'base_lin'")
    assert not any(out.glob("*.h5")), list(out.iterdir())


def test_robot_check_of_a_massless_urdf_is_an_error(tmp_path):
    robot = tmp_path / "massless"
    shutil.copytree(ROOT / "robots" / "scarab2", robot)
    urdf = robot / "robot.urdf"
    import re

    urdf.write_text(re.sub(r'<mass value="[^"]*"', '<mass value="0"', urdf.read_text()))
    result = invoke(["robot", "check", robot / "robot.yaml"])
    assert result.exit_code == 1
    assert "error: robot: the URDF's links have no mass in all" in result.output
    assert "RuntimeWarning" not in result.stderr


@pytest.mark.parametrize("robot, stage", [("scarab2", "step plan"), ("anymal", "dyn simulate")])
def test_an_artefact_made_for_a_changed_robot_is_refused(inputs, tmp_path, monkeypatch, robot, stage):
    robots = tmp_path / "robots"
    shutil.copytree(ROOT / "robots" / robot, robots / robot)
    monkeypatch.setenv("LEGPLAN_ROBOTS", str(robots))
    made = tmp_path / "made.h5"
    if stage == "step plan":
        args = ["steps", "import", inputs["csv"], "--robot", robot, "--map", inputs["map"], "-o", made]
        later = ["step", "plan", inputs["map"], made, "--steps", "0"]
    else:
        args = ["dyn", "plan", inputs["map"], "--robot", robot, "--start", "0", "0", "0", "--goal", "0.3", "0", "0",
                "--strides", "2", "--duration", "1.6", "-o", made]
        later = ["dyn", "simulate", made, inputs["map"]]
    assert invoke([*args, "-q"]).exit_code == 0
    spec = robots / robot / "robot.yaml"
    spec.write_text(spec.read_text() + "\n# edited after the artefact was made\n")
    out = tmp_path / "out.h5"
    assert_refused(invoke([*later, "-o", out]), "made.h5", f"another version of robot '{robot}'", "robot_sha256",
                   output=out)
