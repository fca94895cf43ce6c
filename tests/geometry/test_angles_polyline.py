"""wrap_angle and the arc-length resampler against direct constructions."""

import math

import numpy as np

from legplan.geometry.angles import wrap_angle
from legplan.geometry.polyline import arc_length, resample_by_arc_length


def test_wrap_angle_range_and_equivalence():
    angles = np.linspace(-20.0, 20.0, 4001)
    wrapped = wrap_angle(angles)
    assert np.all(wrapped > -math.pi) and np.all(wrapped <= math.pi)
    np.testing.assert_allclose(np.cos(wrapped), np.cos(angles), atol=1e-12)
    np.testing.assert_allclose(np.sin(wrapped), np.sin(angles), atol=1e-12)
    assert wrap_angle(-math.pi) == math.pi and isinstance(wrap_angle(7.0), float)


def test_resample_by_arc_length_on_an_l_shape_with_a_stop():
    # 3 m along x, a repeated point (a stop), then 4 m along y; times per point
    points = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 0.0], [3.0, 4.0]])
    times = np.array([0.0, 3.0, 5.0, 9.0])
    np.testing.assert_allclose(arc_length(points), [0.0, 3.0, 3.0, 7.0])
    new_points, new_times = resample_by_arc_length(points, np.array([0.0, 1.5, 3.0, 5.0, 7.0]), times)
    np.testing.assert_allclose(new_points, [[0, 0], [1.5, 0], [3, 0], [3, 2], [3, 4]])
    # the stop is skipped (its second point dropped): times interpolate from (3 m, 3 s) to (7 m, 9 s)
    np.testing.assert_allclose(new_times, [0.0, 1.5, 3.0, 6.0, 9.0])


def test_resample_in_three_dimensions():
    points = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 2.0]])  # length 3
    (resampled,) = resample_by_arc_length(points, np.array([0.0, 1.5, 3.0]))
    np.testing.assert_allclose(resampled, [[0, 0, 0], [0.5, 1, 1], [1, 2, 2]])
