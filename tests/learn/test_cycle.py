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
from legplan.learn.network import LearnedInit

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
