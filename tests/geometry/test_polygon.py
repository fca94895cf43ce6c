import numpy as np
import pytest

from legplan.geometry.polygon import ConvexPolygon, convex_hull_2d, support_polygon


def test_hull_drops_interior_and_collinear_points_and_is_ccw():
    pts = np.array([[0, 0], [1, 0], [0.5, 0], [1, 1], [0, 1], [0.5, 0.5], [0.2, 0.7]])
    hull = convex_hull_2d(pts)
    assert sorted(hull.tolist()) == [0, 1, 3, 4]
    poly = ConvexPolygon.from_vertices(pts[hull])
    assert poly.area == pytest.approx(1.0)


def test_square_signed_distance_matches_euclidean_inside_and_half_plane_outside():
    poly = support_polygon(np.array([[0, 0, 0.1], [2, 0, 0], [2, 2, 0], [0, 2, 0.3]]))
    d = poly.signed_distance(np.array([[1.0, 1.0], [0.5, 1.0], [3.0, 1.0], [1.0, -0.25]]))
    np.testing.assert_allclose(d, [1.0, 0.5, -1.0, -0.25])
    # A p <= b exactly inside
    assert np.all(poly.A @ np.array([1.0, 1.0]) <= poly.b)
    assert poly.contains(np.array([[1.0, 1.0]]), margin=0.99)[0]
    assert not poly.contains(np.array([[1.0, 1.0]]), margin=1.01)[0]


def test_gradient_matches_finite_differences():
    rng = np.random.default_rng(0)
    poly = support_polygon(rng.normal(size=(6, 2)))
    pts = rng.normal(size=(50, 2))
    d, g = poly.signed_distance(pts, return_gradient=True)
    h = 1e-7
    for axis in range(2):
        e = np.zeros(2)
        e[axis] = h
        fd = (poly.signed_distance(pts + e) - poly.signed_distance(pts - e)) / (2 * h)
        # away from the ridge where two edges tie, the FD derivative equals the analytic one
        m = np.sort(poly.margins(pts), axis=1)
        clear = m[:, 1] - m[:, 0] > 1e-5
        np.testing.assert_allclose(fd[clear], g[clear, axis], atol=1e-6)


def test_triangle_distance_against_independent_point_line_formula():
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    poly = support_polygon(tri[::-1])  # clockwise input is reordered
    p = np.array([[0.2, 0.2]])
    # distance to hypotenuse x + y = 1 is (1 - 0.4)/sqrt(2) = 0.424 > 0.2 => nearest edges are axes
    assert poly.signed_distance(p)[0] == pytest.approx(0.2)
    q = np.array([[0.45, 0.45]])
    assert poly.signed_distance(q)[0] == pytest.approx((1 - 0.9) / np.sqrt(2))


def test_collinear_footholds_support_nothing():
    poly = support_polygon(np.array([[0, 0], [1, 0], [2, 0]]))
    assert len(poly.vertices) == 2
    d = poly.signed_distance(np.array([[1.0, 0.0], [1.0, 0.3]]))
    np.testing.assert_allclose(d, [0.0, -0.3], atol=1e-12)


def test_single_point_is_rejected():
    with pytest.raises(ValueError):
        support_polygon(np.array([[1.0, 1.0], [1.0, 1.0]]))
