"""TOWR's quadruped gaits: phase counts, footsteps, durations."""

import pytest

from legplan.dyn.gait import make_gait


@pytest.mark.parametrize("name, strides, footsteps", [("trot", 4, 14), ("walk", 4, 16), ("trot", 2, 6), ("walk", 1, 4)])
def test_footstep_counts_match_towr(name, strides, footsteps):
    assert make_gait(name, strides, 3.0).footsteps == footsteps


def test_durations_scaled_and_phases_merged():
    g = make_gait("trot", 4, 2.4)
    assert g.duration == pytest.approx(2.4)
    for leg in range(4):
        phases = g.foot_phases(leg)
        assert phases[0].stance and phases[-1].stance
        assert all(a.stance != b.stance for a, b in zip(phases, phases[1:]))
        assert sum(p.duration for p in phases) == pytest.approx(2.4)
    assert g.contact([0.0, 2.39]).all()  # Stand at both ends
    assert not g.contact([0.45]).any()  # the first flight: (0.3 + 0.4 .. 0.3 + 0.5) s scaled by 2.4 / 4.0


def test_bad_gait_arguments():
    with pytest.raises(ValueError):
        make_gait("gallop", 4, 2.0)
    with pytest.raises(ValueError):
        make_gait("walk", 0, 2.0)
    with pytest.raises(ValueError):
        make_gait("walk", 2, -1.0)


@pytest.mark.parametrize("strides, duration", [(4, 5.5), (2, 3.0), (6, 7.0), (1, 2.0)])
def test_a_slow_trot_stands_on_each_pair_at_most_line_support(strides, duration):
    """Scaled to long pairs, a trot with `line_support` keeps every phase on two feet within it, puts
    four-leg support where the flights were, keeps its footsteps and duration, and each diagonal
    pair still swings together."""
    import numpy as np

    scaled, capped = make_gait("trot", strides, duration), make_gait("trot", strides, duration, line_support=0.29)
    pairs = scaled.stance.sum(axis=1) == 2
    assert scaled.durations[pairs].max() > 0.29
    two = capped.stance.sum(axis=1) == 2
    np.testing.assert_allclose(capped.durations[two], 0.29)
    assert capped.stance.sum(axis=1).min() >= 2                 # no flight left
    assert two.sum() == pairs.sum() and capped.footsteps == scaled.footsteps
    assert capped.duration == pytest.approx(duration)
    for leg, partner in ((0, 3), (1, 2)):                         # lf with rh, rf with lh
        np.testing.assert_array_equal(capped.stance[:, leg], capped.stance[:, partner])
    swings = [p for leg in range(4) for p in capped.foot_phases(leg) if not p.stance]
    assert max(p.duration for p in swings) == pytest.approx(0.29)


def test_a_trot_within_line_support_and_a_walk_are_unchanged():
    import numpy as np

    for name, strides, duration in (("trot", 4, 2.4), ("walk", 4, 5.5)):
        plain, capped = make_gait(name, strides, duration), make_gait(name, strides, duration, line_support=0.29)
        np.testing.assert_array_equal(plain.durations, capped.durations)
        np.testing.assert_array_equal(plain.stance, capped.stance)
    with pytest.raises(ValueError):
        make_gait("trot", 4, 5.5, line_support=0.0)
