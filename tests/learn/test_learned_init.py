"""A learned initializer (init.h5) plugs into the centroidal planner as `legplan.dyn.init` initializers do."""

import numpy as np
import pytest

from legplan.dyn.init import heuristic
from legplan.dyn.planner import plan
from legplan.dyn.problem import DynParams, DynTask, build_problem
from legplan.errors import LegplanError
from legplan.learn.layout import CATEGORIES, join, layout_of
from legplan.learn.network import DEFAULT_WEIGHTS, LearnedInit, fit, save_init
from legplan.learn.space import task_vector


@pytest.fixture(scope="module")
def init_h5(anymal, flat, tmp_path_factory):
    """A network fitted to the Heuristic's guesses of 30 flat 2-stride trots (no solves: fast)."""
    rng = np.random.default_rng(0)
    xs, ys = [], []
    for start in rng.uniform([-0.6, -0.15, -0.2], [-0.3, 0.15, 0.2], (30, 3)):
        problem = build_problem(DynTask(tuple(start), (0.0, 0.0, 0.0), "trot", 2, 2.4), anymal, flat, DynParams(),
                                heuristic)
        xs.append(task_vector(start, (0.0, 0.0, 0.0)))
        ys.append(join({b.name: b.value for b in problem.variables}))
    layout = layout_of(problem.form)
    net, report, _ = fit(np.array(xs), np.array(ys), layout, DEFAULT_WEIGHTS, (8, 8), seed=0)
    path = tmp_path_factory.mktemp("learn") / "init.h5"
    save_init(path, net, layout, {"map": "flat", "gait": "trot", "strides": 2, "duration": 2.4}, report, {}, 0, [],
              False)
    return path


def test_learned_initializer_plans_a_flat_trot(anymal, flat, init_h5):
    learned = LearnedInit(init_h5)
    task = DynTask((-0.45, 0.05, 0.1), (0.0, 0.0, 0.0), "trot", 2, 2.4)
    guess = build_problem(task, anymal, flat, DynParams(), learned)
    reference = build_problem(task, anymal, flat, DynParams(), heuristic)
    for name in (c for c in CATEGORIES if learned.layout[c]):  # it learned the Heuristic: same guess up to the fit
        mine = next(b.value for b in guess.variables if b.name == name)
        theirs = next(b.value for b in reference.variables if b.name == name)
        assert np.max(np.abs(mine - theirs)) < 0.1 * max(1.0, np.abs(theirs).max())
    result = plan(task, anymal, flat, DynParams(), learned)
    assert result.success, result.reason


def test_learned_initializer_refuses_another_layout(anymal, flat, init_h5):
    other = DynTask((-0.45, 0.0, 0.0), (0.0, 0.0, 0.0), "trot", 3, 3.4)
    learned = LearnedInit(init_h5)
    learned.check_task(DynTask((-0.45, 0.0, 0.0), (0.0, 0.0, 0.0), "trot", 2, 2.4))
    with pytest.raises(LegplanError, match="layout/base_lin"):
        learned.check_task(other)  # before planning: dyn plan --init init.h5 can refuse it with exit 2
    with pytest.raises(LegplanError, match="layout/base_lin"):
        build_problem(other, anymal, flat, DynParams(), learned)
