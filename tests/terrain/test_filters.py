"""legplan.terrain.filters gives scipy.ndimage's values bit for bit (the planners use it instead of
importing scipy.ndimage on every run)."""

import numpy as np
import pytest
from scipy import ndimage

from legplan.terrain.filters import gaussian_filter, maximum_filter, square_maximum_filter


def maps():
    rng = np.random.default_rng(7)
    steps = np.zeros((40, 57))
    steps[10:25, 20:40] = 0.165
    steps[:, 50:] = -1.0
    return [rng.normal(size=(31, 23)), steps, np.full((12, 9), 0.3), rng.uniform(0, 0.3, size=(5, 70)),
            np.round(rng.uniform(0, 1, size=(64, 64)), 2)]


@pytest.mark.parametrize("sigma", [0.5, 1.0, 2.0, 2.7, 4.0])
def test_gaussian_filter_is_scipys_bit_for_bit(sigma):
    for h in maps():
        assert np.array_equal(gaussian_filter(h, sigma), ndimage.gaussian_filter(h, sigma, mode="nearest"))


def test_maximum_filter_is_scipys_bit_for_bit():
    rng = np.random.default_rng(3)
    for h in maps():
        for span in (0, 1, 3, 6):
            i, j = np.abs(np.mgrid[-span:span + 1, -span:span + 1])
            for footprint in (np.hypot(i, j) <= span + 0.5, rng.uniform(size=i.shape) < 0.5):
                footprint[span, span] = True
                expected = ndimage.maximum_filter(h, footprint=footprint, mode="nearest")
                assert np.array_equal(maximum_filter(h, footprint), expected)
        for size in (1, 3, 23):
            assert np.array_equal(square_maximum_filter(h, size), ndimage.maximum_filter(h, size=size, mode="nearest"))


def test_maximum_filter_refuses_even_footprints():
    with pytest.raises(ValueError, match="odd"):
        maximum_filter(np.zeros((4, 4)), np.ones((2, 3), bool))
