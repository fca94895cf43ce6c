"""`legplan learn dataset|train` end to end on 6 tiny flat trots; bad input is exit 2 with nothing written."""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from legplan.artefacts import read_summary
from legplan.cli.main import cli
from jobs_support import assert_forked_from_command

ROOT = Path(__file__).resolve().parents[2]
TINY = ROOT / "tests" / "data" / "learn_flat_trot.yaml"  # flat 2-stride trots, 1.2 s, no costs
SPACE = TINY.read_text().replace("../../maps/flat.yaml", f"{ROOT}/maps/flat.yaml")


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("learncli")
    space = tmp / "flat.yaml"
    space.write_text(SPACE)
    result = invoke("learn", "dataset", space, "--n", 6, "--seed", 1, "--iterations", 50, "-o", tmp / "d0.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    result = invoke("learn", "train", tmp / "d0.h5", "--hidden", "8,8", "-o", tmp / "init.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    return tmp, space


def test_dataset_records_tasks_solutions_and_outcomes(trained):
    tmp, _ = trained
    with h5py.File(tmp / "d0.h5", "r") as f:
        assert f.attrs["legplan_kind"] == "dataset" and json.loads(f.attrs["space"])["gait"] == "trot"
        sizes = [int(f[f"layout/{c}"][()]) for c in ("base_lin", "base_ang", "feet", "forces")]
        assert f["x"].shape == (6, 6) and f["y"].shape == (6, sum(sizes)) and np.isfinite(f["y"][()]).all()
        assert f["success"][()].all() and (f["iterations"][()] >= 1).all() and (f["max_violation"][()] <= 1e-3).all()
        assert (f["cost"][()] == 0).all()  # costs: none
        assert np.allclose(f["tasks"][:, 3:], 0.0) and np.all(f["x"][:, 0] <= -0.29)
        assert read_summary(f)["success_rate"][0] == 1.0


def test_dataset_with_two_jobs_is_solved_by_workers_forked_from_the_command(trained, tmp_path):
    """`learn dataset --jobs 2`: the workers are forked from the command with the context it built
    while sampling the tasks, and write the --jobs 1 dataset.h5 of the same seed."""
    tmp, space = trained
    argv = ["learn", "dataset", space, "--n", 6, "--seed", 1, "--iterations", 50]
    assert_forked_from_command(argv, tmp_path / "d0.h5", tmp / "d0.h5")


def test_train_writes_an_init_that_plans_the_next_dataset(trained):
    tmp, space = trained
    with h5py.File(tmp / "init.h5", "r") as f:
        assert f.attrs["legplan_kind"] == "init" and f.attrs["layers"] == 3
        assert read_summary(f)["good"][0] == 6 and json.loads(f.attrs["params"])["hidden"] == [8, 8]
    result = invoke("learn", "dataset", space, "--n", 2, "--seed", 2, "--init", tmp / "init.h5", "--iterations", 25,
                    "-o", tmp / "d1.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(tmp / "d1.h5", "r") as f:
        assert f["success"][()].all() and json.loads(f.attrs["params"])["init"].endswith("init.h5")


def test_train_on_several_datasets_takes_each_tasks_best_converged_outcome(trained):
    """`best_outcomes` per task: the converged outcome of the lowest cost; a dataset of other tasks is
    refused with the file and field named, nothing written."""
    import shutil

    from legplan.learn.dataset import best_outcomes

    tmp, _ = trained
    worse, failed = tmp / "worse.h5", tmp / "failed.h5"
    for path in (worse, failed):
        shutil.copy(tmp / "d0.h5", path)
    with h5py.File(tmp / "d0.h5", "r") as f:
        y0 = f["y"][()]
    with h5py.File(worse, "r+") as f:  # tasks 0-2 better than d0's (cost −1), 3-5 worse (+1), other y
        f["cost"][...] = f["cost"][()] + np.array([-1.0, -1.0, -1.0, 1.0, 1.0, 1.0])
        f["y"][...] = y0 + 1.0
    with h5py.File(failed, "r+") as f:  # the cheapest of all, but not converged
        f["cost"][...] = f["cost"][()] - 5.0
        f["success"][...] = False
        f["y"][...] = y0 + 2.0
    merged = best_outcomes([tmp / "d0.h5", worse, failed])
    assert merged["source"].tolist() == [1, 1, 1, 0, 0, 0]
    assert np.array_equal(merged["y"][:3], y0[:3] + 1.0) and np.array_equal(merged["y"][3:], y0[3:])
    assert merged["success"].all()
    result = invoke("learn", "train", tmp / "d0.h5", worse, failed, "--hidden", "8,8", "-o", tmp / "best.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(tmp / "best.h5", "r") as f:
        summary = read_summary(f)
        assert [summary[f"good_from_{n}"][0] for n in ("d0", "worse", "failed")] == [3, 3, 0]
        assert len(json.loads(f.attrs["inputs"])) == 3
    other = tmp / "other_tasks.h5"
    shutil.copy(tmp / "d0.h5", other)
    with h5py.File(other, "r+") as f:
        f["x"][0, 0] += 0.1
    result = invoke("learn", "train", tmp / "d0.h5", other, "-o", tmp / "x.h5")
    assert result.exit_code == 2 and f"{other}: field 'x'" in result.output
    assert not (tmp / "x.h5").exists()


def test_bad_space_and_foreign_init_are_exit_2_with_no_output(trained):
    tmp, space = trained
    bad = tmp / "bad.yaml"
    bad.write_text(SPACE.replace("strides: 2", "strides: two"))
    result = invoke("learn", "dataset", bad, "--n", 2, "-o", tmp / "x.h5")
    assert result.exit_code == 2 and f"{bad}: field 'strides'" in result.output
    other = tmp / "other.yaml"
    other.write_text(SPACE.replace("strides: 2", "strides: 3").replace("duration: 1.2", "duration: 3.4"))
    result = invoke("learn", "dataset", other, "--n", 2, "--init", tmp / "init.h5", "-o", tmp / "x.h5")
    assert result.exit_code == 2 and "field 'space.strides'" in result.output
    result = invoke("learn", "train", tmp / "d0.h5", "--g-max", "-1", "-o", tmp / "x.h5")
    assert result.exit_code == 2
    result = invoke("learn", "train", tmp / "d0.h5", "--param", "ensemble=0", "-o", tmp / "x.h5")
    assert result.exit_code == 2 and "--param: fit parameters: field 'ensemble'" in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert not (tmp / "x.h5").exists()


def test_train_fit_parameters_give_an_ensemble_recorded_in_the_provenance(trained, tmp_path):
    tmp, _ = trained
    result = invoke("learn", "train", tmp / "d0.h5", "--hidden", "8,8", "--param", "ensemble=2", "--param",
                    "scale=order", "-o", tmp_path / "e.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(tmp_path / "e.h5", "r") as f:
        assert f["network/layer_1/weights"].shape == (16, 16)
        fit = json.loads(f.attrs["params"])["fit"]
        assert {key: fit[key] for key in ("alpha", "scale", "ensemble", "model")} == {
            "alpha": 1e-4, "scale": "order", "ensemble": 2, "model": "network"}


@pytest.mark.parametrize("stage", ["projection", "polish"])
def test_warm_stage_projection_needs_a_learned_init(trained, tmp_path, stage):
    tmp, space = trained
    flat = tmp_path / "flat.h5"
    assert invoke("map", "build", ROOT / "maps" / "flat.yaml", "-o", flat, "-q").exit_code == 0
    for args in (["learn", "dataset", space, "--n", 2, "--warm-stage", stage],
                 ["dyn", "plan", flat, "--start", -0.5, 0.0, 0.0, "--goal", 0.0, 0.0, 0.0, "--warm-stage", stage]):
        result = invoke(*args, "-o", tmp_path / "x.h5")
        assert result.exit_code == 2 and f"--warm-stage {stage}: needs a learned --init" in result.output
        assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "x.h5").exists()
    for value in ("nan", "\udcff\x00", "Projection"):  # not a stage: click's one-line error, exit 2
        result = invoke("learn", "dataset", space, "--n", 2, "--init", tmp / "init.h5", "--warm-stage", value,
                        "-o", tmp_path / "x.h5")
        assert result.exit_code == 2 and "--warm-stage" in result.output and not (tmp_path / "x.h5").exists()
    result = invoke("learn", "dataset", space, "--n", 2, "--seed", 2, "--init", tmp / "init.h5", "--iterations", 25,
                    "--warm-stage", "projection", "-o", tmp_path / "p.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(tmp_path / "p.h5", "r") as f:
        assert f["success"][()].all() and json.loads(f.attrs["params"])["warm_stage"] == "projection"


def test_warm_stage_polish_reads_the_filter_that_learn_train_keeps(trained, tmp_path):
    """init.h5 keeps the training filter as a bound on the cost of each task; an init.h5 without it
    (trained before it was kept) is refused by --warm-stage polish in one line, exit 2, no output."""
    import shutil

    from legplan.learn.network import LearnedInit

    tmp, space = trained
    init = LearnedInit(tmp / "init.h5")
    assert init.bound is not None
    result = invoke("learn", "dataset", space, "--n", 2, "--seed", 2, "--init", tmp / "init.h5", "--iterations", 25,
                    "--warm-stage", "polish", "-o", tmp_path / "p.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(tmp_path / "p.h5", "r") as f:
        assert f["success"][()].all() and json.loads(f.attrs["params"])["warm_stage"] == "polish"
    old = tmp_path / "old.h5"
    shutil.copy(tmp / "init.h5", old)
    with h5py.File(old, "a") as f:
        del f["filter"]
    flat = tmp_path / "flat.h5"
    assert invoke("map", "build", ROOT / "maps" / "flat.yaml", "-o", flat, "-q").exit_code == 0
    for args in (["learn", "dataset", space, "--n", 2],
                 ["dyn", "plan", flat, "--gait", "trot", "--strides", 2, "--duration", 1.2,
                  "--start", -0.5, 0.0, 0.0, "--goal", 0.0, 0.0, 0.0]):
        result = invoke(*args, "--init", old, "--warm-stage", "polish", "-o", tmp_path / "x.h5")
        assert result.exit_code == 2 and f"{old}: field 'filter' is missing" in result.output
        assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "x.h5").exists()
    assert invoke("learn", "dataset", space, "--n", 2, "--init", old, "--warm-stage", "projection",
                  "-o", tmp_path / "y.h5", "-q").exit_code == 0  # the other stages do not read it


def test_cycle_keeps_every_dataset_and_initializer_and_summarizes_each_cycle(trained):
    tmp, space = trained
    out = tmp / "cycle"
    result = invoke("learn", "cycle", space, "--cycles", 2, "--n", 3, "--hidden", "8,8", "--hidden-later", "8,8,8",
                    "--heuristic-iterations", 50, "-o", out, "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    assert {p.name for p in out.iterdir()} == {"dataset_0.h5", "init_1.h5", "dataset_1.h5", "init_2.h5",
                                               "dataset_2.h5", "cycles.json"}
    rows = json.loads((out / "cycles.json").read_text())["cycles"]
    assert [r["init"] for r in rows] == ["heuristic", "init_1.h5", "init_2.h5"] and all(r["tasks"] == 3 for r in rows)
    with h5py.File(out / "dataset_0.h5", "r") as a, h5py.File(out / "dataset_1.h5", "r") as b:
        assert np.array_equal(a["x"][()], b["x"][()])  # Algorithm 1: the same tasks X in every cycle
        assert json.loads(b.attrs["params"])["iterations"] == 25
    with h5py.File(out / "init_2.h5", "r") as f:  # cycle 2 trains on the best outcome of cycles 0 and 1
        summary = read_summary(f)
        assert summary["good_from_dataset_0"][0] + summary["good_from_dataset_1"][0] == summary["good"][0] > 0
        assert [Path(p["path"]).name for p in json.loads(f.attrs["inputs"])] == ["dataset_0.h5", "dataset_1.h5"]
    result = invoke("learn", "cycle", space, "--cycles", 1, "--n", 3, "-o", out)
    assert result.exit_code == 2 and "exists" in result.output


def test_dyn_plan_takes_the_learned_initializer_and_refuses_another_layout(trained, tmp_path):
    tmp, _ = trained
    flat = tmp_path / "flat.h5"
    assert invoke("map", "build", ROOT / "maps" / "flat.yaml", "-o", flat, "-q").exit_code == 0
    common = ["dyn", "plan", flat, "--gait", "trot", "--strides", 2, "--duration", 1.2, "--init", tmp / "init.h5"]
    result = invoke(*common, "--start", -0.5, 0.1, 0.0, "--goal", 0.0, 0.0, 0.0, "-o", tmp_path / "t.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(tmp_path / "t.h5", "r") as f:
        assert json.loads(f.attrs["params"])["init"].endswith("init.h5")
        assert f["tasks/0000"].attrs["success"]
    result = invoke(*common, "--warm-stage", "projection", "--start", -0.5, 0.1, 0.0, "--goal", 0.0, 0.0, 0.0,
                    "-o", tmp_path / "p.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(tmp_path / "p.h5", "r") as f:
        assert json.loads(f.attrs["params"])["dyn"]["warm_stage"] == "projection" and f["tasks/0000"].attrs["success"]
    bad = invoke("dyn", "plan", flat, "--gait", "walk", "--strides", 2, "--duration", 1.2, "--init", tmp / "init.h5",
                 "--start", -0.5, 0.1, 0.0, "--goal", 0.0, 0.0, 0.0, "-o", tmp_path / "u.h5", "-q")
    assert bad.exit_code == 2 and "init.h5" in bad.output and not (tmp_path / "u.h5").exists()


def test_phase_durations_flow_through_dataset_train_and_plan(trained, tmp_path):
    """With --optimize-phases the dataset's y holds the durations (the fifth category), the network
    learns them, and `dyn plan --init` keeps the plan at its predicted timing; an init whose phase
    count fits no problem, and a weights file with a bad phases weight, are exit 2 with no output."""
    tmp, space = trained
    result = invoke("learn", "dataset", space, "--n", 3, "--seed", 1, "--iterations", 60, "--optimize-phases",
                    "-o", tmp_path / "dp.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    with h5py.File(tmp_path / "dp.h5", "r") as f:
        assert int(f["layout/phases"][()]) == 12  # 2 per footstep, 6 footsteps
        assert json.loads(f.attrs["params"])["optimize_phases"] is True and f["success"][()].any()
    result = invoke("learn", "train", tmp_path / "dp.h5", "--hidden", "8,8", "-o", tmp_path / "ip.h5", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    flat = tmp_path / "flat.h5"
    assert invoke("map", "build", ROOT / "maps" / "flat.yaml", "-o", flat, "-q").exit_code == 0
    common = ["dyn", "plan", flat, "--gait", "trot", "--strides", 2, "--duration", 1.2,
              "--start", -0.5, 0.1, 0.0, "--goal", 0.0, 0.0, 0.0, "-q"]
    result = invoke(*common, "--init", tmp_path / "ip.h5", "-o", tmp_path / "t.h5")
    assert result.exit_code == 0, result.output + str(result.exception)
    from legplan.dyn.gait import make_gait
    with h5py.File(tmp_path / "t.h5", "r") as f:
        durations = f["tasks/0000/phases/durations"][()]
        assert f["tasks/0000"].attrs["success"] and json.loads(f.attrs["params"])["dyn"]["optimize_phases"] is False
    assert durations.sum() == pytest.approx(1.2)
    nominal = make_gait("trot", 2, 1.2).durations  # the network's timing (near the gait's here), not the gait's
    assert durations.size != nominal.size or np.abs(durations - nominal).max() > 0
    bad = tmp_path / "bad.h5"
    bad.write_bytes((tmp_path / "ip.h5").read_bytes())
    with h5py.File(bad, "a") as f:
        del f["layout/phases"]
        f["layout/phases"] = np.int64(5)
    result = invoke(*common, "--init", bad, "-o", tmp_path / "u.h5")
    assert result.exit_code == 2 and "field 'layout/phases'" in result.output and not (tmp_path / "u.h5").exists()
    weights = tmp_path / "w.yaml"
    weights.write_text("phases: 0\n")
    result = invoke("learn", "train", tmp_path / "dp.h5", "--weights", weights, "-o", tmp_path / "iw.h5", "-q")
    assert result.exit_code == 2 and "field 'phases'" in result.output and not (tmp_path / "iw.h5").exists()


def test_report_draws_the_dataset_outcomes_and_the_fit(trained):
    from matplotlib.image import imread

    tmp, _ = trained
    result = invoke("report", tmp / "d0.h5", tmp / "init.h5", "-o", tmp / "report", "-q")
    assert result.exit_code == 0, result.output + str(result.exception)
    pngs = {p.name: p for p in (tmp / "report").glob("*.png")}
    outcome = next(p for name, p in pngs.items() if name.endswith("-outcomes.png"))
    assert any(name.endswith("-fit.png") for name in pngs)
    pixels = imread(outcome)[..., :3]
    assert (pixels.std(axis=(0, 1)) > 0.05).any()  # drawn, not blank
    assert "6/6 tasks converged" in (tmp / "report" / "index.html").read_text()


def test_success_within_is_the_fraction_converged_by_each_budget():
    from legplan.learn.figures import success_within

    ok = np.array([True, True, False, True])
    iterations = np.array([3, 10, 25, 0])
    assert success_within(ok, iterations, np.array([0, 2, 3, 9, 10, 100])).tolist() == [0.25, 0.25, 0.5, 0.5, 0.75, 0.75]
