"""Step baseline: polyline resampling and eq. (5) finite differences, and a real jueying_mini step
(box scene of the step-planner tests) judged by the step planner's own dense check and writer."""

import sys
from pathlib import Path

import numpy as np
import pytest

from legplan.baselines.step import (StepBaselineParams, StepBaselineWorker, plan_sequence_baseline,
                                    polyline_quality, polyline_samples)
from legplan.stepplan.batch import read_motion, table2, write_motion
from legplan.stepseq.sequence import StepSequence

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "stepplan"))
from scenes import box_scene  # noqa: E402


def test_polyline_samples_are_uniform_in_arc_length():
    W = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 1.0]])
    X = polyline_samples(W, 9)
    assert np.allclose(X[0], W[0]) and np.allclose(X[-1], W[-1])
    assert np.allclose(np.linalg.norm(np.diff(X, axis=0), axis=1), 0.5)
    assert np.allclose(X[6], [3.0, 0.0])


def test_polyline_quality_length_and_corner_term():
    W = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 1.0]])
    X = polyline_samples(W, 4001)
    length, rough2, rough3 = polyline_quality(X)
    assert length == pytest.approx(4.0)
    # π' = L·u jumps from (4, 0) to (0, 4) at the corner: ∫‖π''‖ dt = ‖Δπ'‖ = 4√2
    assert rough2 == pytest.approx(4.0 * np.sqrt(2.0), rel=1e-3)
    assert rough3 > rough2


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("stepbaseline")
    robot, terrain, map_path, q, stance, footholds = box_scene(tmp)
    seq = StepSequence(q=q, stance=stance, footholds=footholds, robot=robot.name, robot_sha256="test",
                       leg_names=[leg.name for leg in robot.legs], joint_names=robot.joint_names)
    return tmp, map_path, seq


def test_box_steps_planned_judged_and_written_like_ours(box):
    tmp, map_path, seq = box
    # RRT-Connect on the atlas solves this swing within 5 s for most seeds, but which seeds is not
    # portable (its tree diverges with the last bits of the FK floats across CPUs). This test is
    # about judging and writing, not success rates (bench/baselines.py measures those), so it
    # takes the first of a few seeds that plans both steps.
    for seed in range(0, 50, 10):
        params = StepBaselineParams(time_budget=5.0, space="atlas", seed=seed, delta=0.05)
        records = plan_sequence_baseline(seq, map_path, params, range(2))
        if all(r["success"] for r in records):
            break
    assert [r["success"] for r in records] == [True, True], [r["reason"] for r in records]
    worker = StepBaselineWorker(seq.robot, str(map_path), params)
    for r in records:
        W = r["waypoints"]
        x0, x1 = worker.robot.to_vector(np.stack([seq.q[r["index"]], seq.q[r["index"] + 1]]))
        assert np.allclose(W[0], x0, atol=1e-4) and np.allclose(W[-1], x1, atol=1e-4)
        dense = r["dense"]
        assert dense["foot_slip"] <= 1e-3  # judged by pinocchio FK between the manifold waypoints
        assert dense["joint_excess"] == 0.0 and dense["com_margin"] >= -1e-6
        # the resampling's chords cut each corner of the (coarse, delta = 0.05) waypoint polyline
        assert dense["length"] == pytest.approx(np.linalg.norm(np.diff(W, axis=0), axis=1).sum(), rel=5e-3)
    swing = records[1]
    feet = worker.robot.foot_positions(worker.robot.from_vector(swing["waypoints"]))
    assert feet[:, 0, 2].max() > 0.015  # the swinging left front foot rises above the 1.5 cm box
    out = tmp / "motion_ompl.h5"
    write_motion(out, records, seq.robot, params, attrs={"planner": params.planner})
    read = read_motion(out)
    assert [r["planner"] for r in read] == [params.planner] * 2
    assert np.array_equal(read[1]["waypoints"], swing["waypoints"])
    assert read[1]["dense"] == pytest.approx(swing["dense"])
    assert table2(read)["worst_violation"][0] == pytest.approx(max(r["dense"]["foot_slip"] for r in records))
