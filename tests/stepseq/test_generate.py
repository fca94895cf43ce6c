"""Step-sequence generation: a dead end takes the previous move back and tries its next option."""

import numpy as np
import pytest

from legplan.stepseq.generate import GenerateParams, StepGenerator, _option


def test_dead_end_takes_the_last_move_back(scarab, flat_map, monkeypatch):
    terrain, _ = flat_map
    made = []  # (move index, option) of every move _move returned
    original = StepGenerator._move

    def move_with_a_dead_end(self, x, stance, footholds, move, banned=frozenset()):
        if move == 2 and not made[2:]:
            made.append((move, "dead end"))
            return "move 2: planted dead end"
        outcome = original(self, x, stance, footholds, move, banned)
        if not isinstance(outcome, str):
            made.append((move, _option(*outcome[1:])))
        return outcome

    monkeypatch.setattr(StepGenerator, "_move", move_with_a_dead_end)
    generated = StepGenerator(scarab, terrain, GenerateParams(max_moves=4)).plan((-0.05, 0, 0), (0.05, 0, 0))
    assert made[2] == (2, "dead end")
    assert made[3][0] == 1 and made[3][1] != made[1][1]  # move 1 taken back and replaced by another option
    assert [m["move"] for m in generated.moves] == list(range(len(generated.moves)))
    assert len(generated.moves) >= 3
    switched = np.abs(np.diff(generated.stance.astype(int), axis=0)).sum(axis=1)
    assert np.all(switched <= 1)  # the sequence stays consistent: one leg changes at a time


def test_dead_ends_beyond_the_budget_stop_with_the_reason(scarab, flat_map, monkeypatch):
    terrain, _ = flat_map
    original = StepGenerator._move

    def dead_from_move_1(self, x, stance, footholds, move, banned=frozenset()):
        return f"move {move}: always stuck" if move >= 1 else original(self, x, stance, footholds, move, banned)

    monkeypatch.setattr(StepGenerator, "_move", dead_from_move_1)
    generated = StepGenerator(scarab, terrain, GenerateParams(backtracks=2)).plan((-0.05, 0, 0), (0.05, 0, 0))
    assert not generated.success and generated.reason == "move 1: always stuck"
    assert len(generated.moves) == 1


def test_the_target_pose_turns_the_short_way_round(scarab, flat_map):
    generator = StepGenerator(scarab, flat_map[0], GenerateParams())
    generator.start, generator.goal = np.array([0.0, 0.0, 3.0]), np.array([0.2, 0.0, -3.0])
    xy, yaw = generator._pose(0.5)
    np.testing.assert_allclose(xy, [0.1, 0.0])
    assert yaw == pytest.approx(3.0 + (2 * np.pi - 6.0) / 2)  # through ±π, not back through 0
