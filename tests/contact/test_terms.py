import numpy as np
import pytest

from legplan.contact import (ContactMode, collision_terms, com_terms, foot_target_terms, joint_limit_terms,
                             stance_foot_terms)
from legplan.solve import check_jacobian


def _state(robot, seed):
    rng = np.random.default_rng(seed)
    x = robot.to_vector(robot.q_nominal[None])[0]
    x = x + rng.normal(scale=0.05, size=x.shape)
    x[3:6] += [0.1, -0.05, 0.4]
    feet = robot.foot_positions(robot.from_vector(x[None]))[0]
    stance = np.ones(robot.n_legs, bool)
    stance[2] = False
    footholds = feet + rng.normal(scale=0.01, size=feet.shape)
    return x, ContactMode(stance=stance, footholds=footholds, com_margin=0.03, clearance=0.02)


def _single(term):
    return lambda x: tuple(a[0] for a in term(x[None]))


@pytest.mark.parametrize("seed", [0, 1])
def test_term_jacobians_match_finite_differences(scarab, step_terrain, seed):
    x, mode = _state(scarab, seed)
    terms = {
        "stance": lambda X: stance_foot_terms(scarab, X, mode),
        "target": lambda X: foot_target_terms(scarab, X, [2], [[0.0, 0.3, 0.05]]),
        "com": lambda X: com_terms(scarab, X, mode),
        "collision": lambda X: collision_terms(scarab, X, mode, step_terrain.sdf),
        "joints": lambda X: joint_limit_terms(scarab, X),
    }
    for name, term in terms.items():
        report = check_jacobian(_single(term), x)
        assert report.ok(atol=1e-6, rtol=1e-4), (name, report)


def test_batched_terms_equal_per_configuration_terms(scarab, step_terrain):
    x0, mode = _state(scarab, 3)
    X = np.stack([x0, x0 + 0.01, x0 - 0.02])
    values, jac = collision_terms(scarab, X, mode, step_terrain.sdf)
    assert values.shape[0] == 3 and jac.shape == values.shape + (scarab.nx,)
    for i in range(3):
        v, j = collision_terms(scarab, X[i:i + 1], mode, step_terrain.sdf)
        np.testing.assert_allclose(values[i], v[0])
        np.testing.assert_allclose(jac[i], j[0])


def test_com_term_is_margin_minus_independent_edge_distance(scarab):
    x, mode = _state(scarab, 4)
    values, _ = com_terms(scarab, x[None], mode)
    com = scarab.com(scarab.from_vector(x[None]))[0]
    # edge distances by the point-line formula on the hull of the stance footholds
    v = mode.polygon.vertices
    dists = []
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        e = b - a
        dists.append((e[0] * (com[1] - a[1]) - e[1] * (com[0] - a[0])) / np.linalg.norm(e))
    np.testing.assert_allclose(values[0], mode.com_margin - np.array(dists), atol=1e-12)


def test_stance_foot_spheres_are_exempt_and_swing_foot_uses_foot_clearance(scarab, flat_terrain):
    from legplan.contact import sphere_margins
    x, mode = _state(scarab, 5)
    margins = sphere_margins(scarab, mode)
    feet = np.flatnonzero(scarab.spheres.is_foot)
    swing_foot = feet[scarab.spheres.leg_index[feet] == 2]
    assert np.isnan(margins[np.setdiff1d(feet, swing_foot)]).all()
    assert margins[swing_foot] == pytest.approx(mode.foot_clearance)
    values, _ = collision_terms(scarab, x[None], mode, flat_terrain.sdf)
    assert values.shape[1] == len(margins) - (len(feet) - 1)


def test_block_tangent_product_is_the_dense_product_bit_for_bit(scarab):
    """The terms map Jacobians to x by the tangent map's blocks: the same numbers as the dense einsum."""
    from legplan.contact.terms import block_tangent_product

    rng = np.random.default_rng(4)
    X = scarab.to_vector(scarab.q_nominal[None]) + rng.normal(scale=0.3, size=(9, scarab.nx))
    tangent = scarab.tangent_map(X)
    for shape in ((9, scarab.nv), (9, 5, 3, scarab.nv), (9, 3, scarab.nv)):
        jac_v = rng.normal(size=shape) * (rng.random(shape) > 0.3)
        assert np.array_equal(block_tangent_product(jac_v, tangent), np.einsum("n...v,nvx->n...x", jac_v, tangent))


def test_nearest_end_is_the_distance_numpy_norm_gives_and_its_direction():
    """Distances to the nearer end bit for bit as `np.linalg.norm` forms them; the unit vector points from
    that end to the centre."""
    from legplan.contact.terms import nearest_end

    rng = np.random.default_rng(2)
    centres, ends = rng.normal(size=(7, 3, 3)), rng.normal(size=(2, 3, 3))
    norms = np.linalg.norm(centres[None] - ends[:, None], axis=-1)
    assert np.array_equal(nearest_end(centres, ends), norms.min(axis=0))
    d, unit = nearest_end(centres, ends, True)
    assert np.array_equal(d, norms.min(axis=0))
    nearer = ends[norms.argmin(axis=0), np.arange(3)]
    np.testing.assert_allclose(nearer + d[..., None] * unit, centres, atol=1e-12)
