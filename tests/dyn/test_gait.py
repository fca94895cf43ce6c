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
