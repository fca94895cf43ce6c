"""Algorithm 1 as the library function `legplan.learn.cycle.run_cycle`, and the one `--init` resolver."""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from legplan.dyn.init import heuristic
from legplan.errors import LegplanError
from legplan.learn.cycle import run_cycle
from legplan.learn.initializers import check_warm_stage, initializer
from legplan.learn.network import FitParams, LearnedInit

ROOT = Path(__file__).resolve().parents[2]

SPACE = (ROOT / "tests" / "data" / "learn_flat_trot.yaml").read_text().replace("../../maps/flat.yaml",
                                                                               f"{ROOT}/maps/flat.yaml")


def test_run_cycle_solves_trains_and_solves_again_on_the_same_tasks(tmp_path):
    space = tmp_path / "flat.yaml"
    space.write_text(SPACE)
    out, lines = tmp_path / "cycle", []
    rows = run_cycle(space, out, count=3, cycles=1, seed=1, heuristic_iterations=50, hidden=(8, 8),
                     hidden_later=(8, 8), report=lines.append)
    assert {p.name for p in out.iterdir()} == {"dataset_0.h5", "init_1.h5", "dataset_1.h5", "cycles.json"}
    assert [r["init"] for r in rows] == ["heuristic", "init_1.h5"] and all(r["tasks"] == 3 for r in rows)
    assert json.loads((out / "cycles.json").read_text())["cycles"] == rows
    with h5py.File(out / "dataset_0.h5", "r") as a, h5py.File(out / "dataset_1.h5", "r") as b:
        assert np.array_equal(a["x"][()], b["x"][()])  # the same tasks X in every cycle
        assert json.loads(a.attrs["params"])["iterations"] == 50 and json.loads(b.attrs["params"])["iterations"] == 25
        assert json.loads(b.attrs["params"])["init"].endswith("init_1.h5")
    assert sum(line.startswith("cycle ") for line in lines) == 2 and lines[-1].endswith("cycles.json")
    with pytest.raises(LegplanError, match="dataset_0.h5: output exists"):  # refused before any work
        run_cycle(space, out, count=3, cycles=1, report=lines.append)
    before = (out / "init_1.h5").stat().st_mtime_ns
    again = run_cycle(space, out, count=3, cycles=1, resume=True, report=lines.append)  # every artefact reused
    assert again == rows and (out / "init_1.h5").stat().st_mtime_ns == before


def _arrays(path):
    """Every dataset of an HDF5 file, by name."""
    arrays = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, node: arrays.__setitem__(name, node[()]) if isinstance(node, h5py.Dataset) else None)
    return arrays


def test_the_same_seed_trains_the_same_network_bit_for_bit(tmp_path):
    """Algorithm 1 run twice with one seed (what the shipped initializers record, `learn shipped`):
    the same tasks, solutions and network weights, every array bit for bit (clock values aside);
    another seed draws other tasks and trains another network."""
    space = tmp_path / "flat.yaml"
    space.write_text(SPACE)
    for name, seed in (("a", 1), ("b", 1), ("c", 2)):
        run_cycle(space, tmp_path / name, count=3, cycles=1, seed=seed, heuristic_iterations=50, hidden=(8, 8),
                  hidden_later=(8, 8), report=lambda line: None)
    for artefact in ("dataset_0.h5", "init_1.h5", "dataset_1.h5"):
        a, b = _arrays(tmp_path / "a" / artefact), _arrays(tmp_path / "b" / artefact)
        assert a.keys() == b.keys() and len(a) > 3
        for key in a:
            if key == "summary":  # name → value, its clock rows (median_seconds) aside
                a[key], b[key] = ({row["name"]: row["value"] for row in rows if b"seconds" not in row["name"]}
                                  for rows in (a[key], b[key]))
                assert a[key].keys() == b[key].keys()
                a[key], b[key] = (np.array(list(values.values())) for values in (a[key], b[key]))
            if key != "seconds":  # the solves' clock
                equal_nan = a[key].dtype.kind == "f"  # NaN marks a value that does not exist, in both
                assert np.array_equal(a[key], b[key], equal_nan=equal_nan), f"{artefact}:{key}"
    first, other = LearnedInit(tmp_path / "a" / "init_1.h5"), LearnedInit(tmp_path / "c" / "init_1.h5")
    assert not np.array_equal(_arrays(tmp_path / "a" / "dataset_0.h5")["x"], _arrays(tmp_path / "c" / "dataset_0.h5")["x"])
    assert not all(np.array_equal(u, v) for u, v in zip(first.net.weights, other.net.weights))


def test_a_cycle_of_polynomial_fits_records_them_and_repeats_bit_for_bit(tmp_path):
    """`fit_params` reach every cycle's training: a polynomial A_θ, in init.h5 and its provenance;
    the same seed again gives the same polynomial."""
    space = tmp_path / "flat.yaml"
    space.write_text(SPACE)
    polynomial = FitParams(model="polynomial", degree=2)
    for name in ("a", "b"):
        run_cycle(space, tmp_path / name, count=3, cycles=1, seed=1, heuristic_iterations=50, fit_params=polynomial,
                  report=lambda line: None)
    first, again = (LearnedInit(tmp_path / name / "init_1.h5") for name in ("a", "b"))
    assert first.net.degree == 2 and len(first.net.weights) == 1
    assert all(np.array_equal(u, v) for u, v in zip(first.net.weights + first.net.biases, again.net.weights + again.net.biases))
    with h5py.File(tmp_path / "a" / "init_1.h5", "r") as f:
        assert json.loads(f.attrs["params"])["fit"] == polynomial.as_dict()


def test_the_init_resolver_hands_the_planner_an_initializer_object(tmp_path):
    assert initializer("heuristic") is heuristic
    for name, message in (("learned", "--init: unknown initializer 'learned'"),
                          (str(tmp_path / "none.h5"), "no such file")):
        with pytest.raises(LegplanError, match=message):
            initializer(name)
    with pytest.raises(LegplanError, match="--warm-stage projection: needs a learned --init"):
        check_warm_stage("projection", "heuristic")
    check_warm_stage("costs", "heuristic")
    assert LearnedInit.near_solution  # what the planner reads of a learned initializer
