import numpy as np
import pytest

from legplan.validate.surface import SurfaceMesh


def _step_map():
    """1.2 m x 1.0 m at 2 cm; ground z=0.1 with a 0.3 m-wide pit of depth 0.4 across x in [0.5, 0.8]."""
    h = np.full((51, 61), 0.1)
    x = np.arange(61) * 0.02
    h[:, (x >= 0.5) & (x <= 0.8)] = -0.3
    return h


def test_point_over_flat_ground_distance_is_height_above_it():
    mesh = SurfaceMesh(np.zeros((40, 40)), origin=(-0.4, -0.4), resolution=0.02)
    pts = np.array([[0.0, 0.0, 0.05], [0.1, -0.1, 0.3], [0.05, 0.05, -0.02]])
    np.testing.assert_allclose(mesh.signed_distance(pts), [0.05, 0.3, -0.02], atol=1e-8)
    # FCL itself (no shortcut) agrees with the height
    np.testing.assert_allclose(mesh.fcl_distance(pts), [0.05, 0.3, -0.02], atol=1e-8)


def test_surface_height_is_the_top_of_the_containing_column():
    h = np.array([[0.0, 1.0], [2.0, 4.0]])
    mesh = SurfaceMesh(h, origin=(0.0, 0.0), resolution=1.0)
    np.testing.assert_allclose(mesh.surface_height(np.array([[0.4, 0.1], [0.6, 0.4], [0.2, 0.7], [3.0, 3.0]])),
                               [0.0, 1.0, 2.0, 4.0])


def test_bounds_bracket_fcl_and_signed_distance_matches_fcl_everywhere():
    mesh = SurfaceMesh(_step_map(), origin=(0.0, 0.0), resolution=0.02, window=0.1)
    rng = np.random.default_rng(3)
    pts = rng.uniform([0.2, 0.2, -0.35], [1.0, 0.8, 0.4], size=(400, 3))
    exact = mesh.fcl_distance(pts)
    lb, ub, is_exact = mesh.distance_bounds(pts)
    assert np.all(lb <= exact + 1e-9) and np.all(exact <= ub + 1e-9)
    assert is_exact.any() and (~is_exact).any()
    np.testing.assert_allclose(mesh.signed_distance(pts), exact, atol=1e-8)


def test_point_beside_a_wall_measures_horizontal_distance_to_the_column_face():
    mesh = SurfaceMesh(_step_map(), origin=(0.0, 0.0), resolution=0.02)
    # the pit columns end at x = 0.80 + 0.01; a point at x = 0.75, 0.1 m below the rim, is 0.06 m
    # from that wall and 0.2 m above the pit floor
    d = mesh.signed_distance(np.array([[0.75, 0.5, 0.0]]))[0]
    assert d == pytest.approx(0.06, abs=1e-9)
    # just above the rim edge, diagonal to the corner of the column top
    d = mesh.signed_distance(np.array([[0.78, 0.5, 0.13]]))[0]
    assert d == pytest.approx(np.hypot(0.03, 0.03), abs=1e-9)
    # inside the ground column, 2 cm below its top and 5 cm from the wall: -0.02
    assert mesh.signed_distance(np.array([[0.88, 0.5, 0.08]]))[0] == pytest.approx(-0.02, abs=1e-9)


def _column_solid_distance(height, origin, r, points):
    """Unsigned distance of points (n, 3) to the column solid's surface, by brute force over every
    column top (a square) and every wall between neighbouring columns of different height (a
    vertical rectangle): an independent reference for the merged triangle mesh."""
    ny, nx = height.shape
    iy, ix = np.mgrid[0:ny, 0:nx]
    cx, cy = origin[0] + r * ix.ravel(), origin[1] + r * iy.ravel()
    p = points[:, None, :]
    dx = np.maximum(np.abs(p[..., 0] - cx) - r / 2, 0.0)
    dy = np.maximum(np.abs(p[..., 1] - cy) - r / 2, 0.0)
    best = np.sqrt(dx ** 2 + dy ** 2 + (p[..., 2] - height.ravel()) ** 2).min(axis=1)
    for axis in (0, 1):  # walls facing x (between columns ix, ix + 1), then y
        a = height[:, :-1] if axis == 0 else height[:-1, :]
        b = height[:, 1:] if axis == 0 else height[1:, :]
        jy, jx = np.nonzero(a != b)
        wx, wy = origin[0] + r * jx, origin[1] + r * jy
        lo, hi = np.minimum(a, b)[jy, jx], np.maximum(a, b)[jy, jx]
        if axis == 0:
            across, along = p[..., 0] - (wx + r / 2), np.maximum(np.abs(p[..., 1] - wy) - r / 2, 0.0)
        else:
            across, along = p[..., 1] - (wy + r / 2), np.maximum(np.abs(p[..., 0] - wx) - r / 2, 0.0)
        dz = np.maximum(np.maximum(lo - p[..., 2], p[..., 2] - hi), 0.0)
        if len(jx):
            best = np.minimum(best, np.sqrt(across ** 2 + along ** 2 + dz ** 2).min(axis=1))
    return best


@pytest.mark.parametrize("kind", ["steps", "levels", "noise"])
def test_fcl_distance_equals_the_column_solid_surface_distance(kind):
    """The mesh merges equal column tops into rectangles; FCL's distances to it are those to the
    column solid's surface (tops and walls), on maps with large flat areas, a few levels, and none."""
    rng = np.random.default_rng(5)
    height = {"steps": _step_map()[::3, ::3], "levels": rng.integers(0, 3, (14, 18)) * 0.05,
              "noise": rng.normal(0.0, 0.02, (12, 12))}[kind]
    origin, r = np.array([0.1, -0.2]), 0.06
    mesh = SurfaceMesh(height, origin=origin, resolution=r)
    ny, nx = height.shape
    points = rng.uniform([origin[0], origin[1], height.min() - 0.1],
                         [origin[0] + r * (nx - 1), origin[1] + r * (ny - 1), height.max() + 0.2], size=(300, 3))
    np.testing.assert_allclose(np.abs(mesh.fcl_distance(points)), _column_solid_distance(height, origin, r, points),
                               atol=1e-9)
