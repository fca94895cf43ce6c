"""Shipped trained initializers: `ship_initializer` (provenance, held-out results), `--init NAME`, and the
refusal of tasks outside the trained space."""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

import legplan.shipped
from legplan.cli.main import cli
from legplan.dyn.problem import DynTask
from legplan.errors import LegplanError
from legplan.learn.cycle import run_cycle
from legplan.learn.dataset import make_dataset
from legplan.learn.initializers import initializer, is_learned, resolve_init
from legplan.learn.network import LearnedInit
from legplan.learn.shipping import ship_initializer, shipped_records
from legplan.learn.space import read_space

ROOT = Path(__file__).resolve().parents[2]
SPACE = (ROOT / "tests" / "data" / "learn_flat_trot.yaml").read_text().replace("../../maps/flat.yaml",
                                                                               f"{ROOT}/maps/flat.yaml")


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A one-cycle training (seed 1) of the tiny flat-trot space and a held-out dataset (seed 2)."""
    work = tmp_path_factory.mktemp("ship")
    space = work / "tiny_trot.yaml"
    space.write_text(SPACE)
    run_cycle(space, work / "cycle", count=3, cycles=1, seed=1, heuristic_iterations=50, hidden=(8, 8),
              hidden_later=(8, 8), report=lambda line: None)
    init = work / "cycle" / "init_1.h5"
    make_dataset(read_space(space), space, 2, 2, str(init), 25, work / "held_out.h5")
    make_dataset(read_space(space), space, 2, 1, str(init), 25, work / "seen.h5")  # the training's seed
    return work, init


def test_ship_writes_the_init_and_its_provenance_with_held_out_results(trained, tmp_path):
    work, init = trained
    record = ship_initializer(init, work / "held_out.h5", tmp_path / "out")
    assert record["name"] == "tiny_trot"
    shipped = tmp_path / "out" / "tiny_trot.h5"
    with h5py.File(init, "r") as f, h5py.File(shipped, "r") as g:
        assert record["trained"]["command"] == json.loads(f.attrs["command"])  # as the init.h5 records it
        assert json.loads(g.attrs["params"]) == json.loads(json.dumps({k: record[k] for k in ("trained", "held_out")}))
        assert [r["path"] for r in json.loads(g.attrs["inputs"])] == [str(init), str(work / "held_out.h5")]
        assert g.attrs["space"] == f.attrs["space"]
    original, copy = LearnedInit(init), LearnedInit(shipped)  # the same network
    assert all(np.array_equal(a, b) for a, b in zip(original.net.weights, copy.net.weights))
    assert [d["path"] for d in record["trained"]["datasets"]] == ["dataset_0.h5"]
    held = record["held_out"]
    assert held["seed"] == 2 and held["tasks"] == 2 and 0.0 <= held["success_rate"] <= 1.0
    with pytest.raises(LegplanError, match="exists"):
        ship_initializer(init, work / "held_out.h5", tmp_path / "out")


def test_ship_refuses_a_dataset_that_is_not_held_out_or_not_solved_from_the_init(trained, tmp_path):
    work, init = trained
    with pytest.raises(LegplanError, match="field 'seed': 1 is a seed of the training"):
        ship_initializer(init, work / "seen.h5", tmp_path)
    with pytest.raises(LegplanError, match="field 'inputs': not solved from"):
        ship_initializer(init, work / "cycle" / "dataset_0.h5", tmp_path)
    assert not list(tmp_path.iterdir())


def test_init_by_name_resolves_a_shipped_initializer_and_refuses_tasks_outside_its_space(trained, tmp_path,
                                                                                         monkeypatch):
    work, init = trained
    tasks = tmp_path / "tasks"
    ship_initializer(init, work / "held_out.h5", tasks / legplan.shipped.INITIALIZERS)
    monkeypatch.setattr(legplan.shipped, "shipped_dir", lambda kind: tmp_path / kind)
    assert resolve_init("tiny_trot") == str(tasks / "initializers" / "tiny_trot.h5") and is_learned("tiny_trot")
    assert resolve_init("heuristic") == "heuristic" and resolve_init("other") == "other"
    assert [(r["name"], r["held_out"]["seed"]) for r in shipped_records()] == [("tiny_trot", 2)]
    learned = initializer("tiny_trot")
    assert isinstance(learned, LearnedInit)
    learned.check_in_space(DynTask((-0.6, 0.15, 0.2), (0.0, 0.0, 0.0), "trot", 2, 2.4))  # on the bounds
    for start, goal, message in (((-0.7, 0.0, 0.0), (0.0, 0.0, 0.0), "start x = -0.7 lies outside"),
                                 ((-0.5, 0.0, 0.3), (0.0, 0.0, 0.0), "start yaw = 0.3 lies outside"),
                                 ((-0.5, 0.0, 0.0), (0.1, 0.0, 0.0), "goal x = 0.1 lies outside")):
        with pytest.raises(LegplanError, match=message):
            learned.check_in_space(DynTask(start, goal, "trot", 2, 2.4))
    with pytest.raises(LegplanError, match="or a shipped one: tiny_trot"):
        initializer("tiny_trott")


def test_dyn_plan_refuses_a_task_outside_the_shipped_space_before_writing(trained, tmp_path, monkeypatch):
    work, init = trained
    built = CliRunner().invoke(cli, ["map", "build", str(ROOT / "maps" / "flat.yaml"), "-o", str(tmp_path / "flat.h5")])
    assert built.exit_code == 0, built.output
    ship_initializer(init, work / "held_out.h5", tmp_path / "tasks" / legplan.shipped.INITIALIZERS)
    monkeypatch.setattr(legplan.shipped, "shipped_dir", lambda kind: tmp_path / kind)
    out = tmp_path / "traj.h5"
    result = CliRunner().invoke(cli, ["dyn", "plan", str(tmp_path / "flat.h5"), "--gait", "trot", "--strides", "2", "--duration",
                                      "1.2", "--start", "-1.0", "0", "0", "--goal", "0", "0", "0",
                                      "--init", "tiny_trot", "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert "start x = -1 lies outside the range it was trained on" in result.output
    assert not out.exists()


SHIPPED_CASES = {
    # space: a held-out task's start (a task of seed 1 by `learn dataset`) that its network converges on
    "double_pallet_walk": ("-0.535", "-0.148", "-0.214"),
    "flat_trot": ("-0.455", "-0.136", "0.052"),
    "jueying_flat_trot": ("-0.386", "-0.073", "0.052"),
    "single_pallet_walk": ("-0.672", "-0.136", "0.052"),
}


def shipped_space(name):
    """The shipped task space tasks/NAME.yaml, read as `learn dataset NAME` reads it."""
    return read_space(legplan.shipped.resolve_shipped(name, "tasks"))


def test_every_shipped_initializer_is_planned_here():
    assert sorted(SHIPPED_CASES) == legplan.shipped.list_shipped_initializers()


@pytest.mark.parametrize("space", sorted(SHIPPED_CASES))
def test_a_shipped_initializer_plans_a_held_out_task_by_name(space, tmp_path):
    """`dyn plan --init SPACE` from a fresh checkout: the shipped network (held-out results of another
    seed in its provenance) plans a held-out task of its space, and the check passes."""
    spec = shipped_space(space)
    (record,) = [r for r in shipped_records() if r["name"] == space]
    assert record["held_out"]["tasks"] == 100 and record["held_out"]["seed"] != record["trained"]["seed"]
    map_path = tmp_path / "map.h5"
    built = CliRunner().invoke(cli, ["map", "build", spec.map, "-o", str(map_path), "-q"])
    assert built.exit_code == 0, built.output
    out = tmp_path / "traj.h5"
    goal = [f"{lo:g}" for lo, _ in spec.goal]
    result = CliRunner().invoke(cli, ["dyn", "plan", str(map_path), "--robot", spec.robot, "--gait", spec.gait,
                                      "--strides", str(spec.strides), "--duration", str(spec.duration), "--costs",
                                      spec.costs, "--start", *SHIPPED_CASES[space], "--goal", *goal,
                                      "--init", space, "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "1/1 tasks planned" in result.output and "check passed" in result.output
    iterations = int(result.output.split(" iterations,")[0].rsplit(" ", 1)[-1])
    assert iterations <= 25  # N_θ, the budget of a learned start (Algorithm 1)


@pytest.mark.parametrize("space", sorted(SHIPPED_CASES))
def test_a_shipped_initializer_refuses_a_task_outside_its_space(space, tmp_path):
    """A task 5 cm or 0.05 rad past any bound of the shipped space is refused before planning, by the
    library (each bound) and by `dyn plan --init SPACE` (exit 2, one line, nothing written)."""
    spec, learned = shipped_space(space), initializer(space)
    assert learned.space["start"] == [list(r) for r in spec.start] and learned.space["goal"] == [list(r) for r in spec.goal]
    centre = [[(lo + hi) / 2 for lo, hi in ranges] for ranges in (spec.start, spec.goal)]
    learned.check_in_space(spec.task(*[[lo for lo, _ in ranges] for ranges in (spec.start, spec.goal)]))  # on them
    learned.check_in_space(spec.task(*[[hi for _, hi in ranges] for ranges in (spec.start, spec.goal)]))
    for end, ranges in enumerate((spec.start, spec.goal)):
        for axis, (lo, hi) in enumerate(ranges):
            for value in (lo - 0.05, hi + 0.05):
                pose = [list(c) for c in centre]
                pose[end][axis] = value
                with pytest.raises(LegplanError, match=f"{('start', 'goal')[end]} {('x', 'y', 'yaw')[axis]} = "
                                                        f"{value:g} lies outside the range it was trained on"):
                    learned.check_in_space(spec.task(*pose))
    map_path = tmp_path / "map.h5"
    assert CliRunner().invoke(cli, ["map", "build", spec.map, "-o", str(map_path), "-q"]).exit_code == 0
    out, far = tmp_path / "traj.h5", spec.start[0][0] - 0.05
    result = CliRunner().invoke(cli, ["dyn", "plan", str(map_path), "--robot", spec.robot, "--gait", spec.gait,
                                      "--strides", str(spec.strides), "--duration", str(spec.duration), "--costs",
                                      spec.costs, "--start", f"{far:g}", *(f"{c:g}" for c in centre[0][1:]),
                                      "--goal", *(f"{c:g}" for c in centre[1]), "--init", space, "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert f"start x = {far:g} lies outside the range it was trained on" in result.output
    assert not out.exists()


@pytest.mark.parametrize("space", sorted(SHIPPED_CASES))
def test_a_shipped_initializer_records_the_training_that_makes_it_again(space):
    """What a shipped network was trained on is the shipped space as it reads today (same map content,
    robot, gait, timing, costs and ranges: a space changed after its training fails here), and its
    provenance names the command, its seed and the sha256 of every dataset, so the same `learn cycle`
    run again gives the same network (same seed, same network: tests/learn/test_cycle.py)."""
    (record,) = [r for r in shipped_records() if r["name"] == space]
    today = {key: value for key, value in shipped_space(space).record().items() if key != "map"}
    assert {key: value for key, value in record["space"].items() if key != "map"} == json.loads(json.dumps(today))
    trained = record["trained"]
    command = trained["command"]
    assert command[1:3] == ["learn", "cycle"] and Path(command[3]).name == f"{space}.yaml"
    assert command[command.index("--seed") + 1] == str(trained["seed"])
    assert trained["datasets"] and all(len(d["sha256"]) == 64 for d in trained["datasets"])
    assert record["held_out"]["seed"] != trained["seed"] and len(record["held_out"]["dataset_sha256"]) == 64


def test_the_training_pipeline_declares_every_shipped_space():
    """pipelines/train_initializers.yaml makes every shipped initializer: per space a `learn cycle` of
    tasks/NAME.yaml, held-out tasks of another seed solved from its last network, and `learn ship`."""
    from legplan.pipeline import load_pipeline

    pipeline = load_pipeline(ROOT / "pipelines" / "train_initializers.yaml")
    for name in legplan.shipped.list_shipped_initializers():
        cycle, held, ship = (pipeline.stage(f"{name}_{part}") for part in ("cycle", "held_out", "ship"))
        assert list(cycle.command[:2]) == ["learn", "cycle"] and cycle.command[2].endswith(f"/{name}.yaml")
        assert list(held.command[:2]) == ["learn", "dataset"] and held.params["seed"] != cycle.params["seed"]
        assert list(ship.command[:2]) == ["learn", "ship"] and ship.provenance.endswith(f"shipped/{name}/{name}.h5")
