"""The vectorized child expansion against a straightforward per-primitive evaluation."""

import numpy as np
import pytest

from legplan.nav import NavParams
from legplan.nav.primitives import PrimitiveSet, input_lattice, sample_count


def reference_children(grid, params, p0, v0):
    """Per primitive: end state, feasibility and edge cost from eqs. (6), (8), (17), (18)."""
    inputs = input_lattice(params.mu, params.a_max)
    count = sample_count(params.v_max, params.tau, grid.resolution)
    t = np.linspace(0.0, params.tau, count)[:, None]
    dt = params.tau / (count - 1)
    children = []
    for u in inputs:
        samples = p0 + v0 * t + 0.5 * u * t**2
        velocities = v0 + u * t
        feasible = not grid.blocked_at(samples).any() and \
            np.abs(velocities[-1]).max() <= params.v_max
        collision = np.sum(grid.cost_at(samples) * np.linalg.norm(velocities, axis=1)) * dt
        cost = (u @ u + params.rho) * params.tau + params.rho_c * collision
        children.append((samples[-1], velocities[-1], feasible, cost))
    return children


@pytest.mark.parametrize("rho_c", [0.01, 0.0])
def test_expand_matches_per_primitive_evaluation(pillars_grid, rho_c):
    params = NavParams(rho_c=rho_c)
    prims = PrimitiveSet.build(params, pillars_grid)
    rng = np.random.default_rng(11)
    xmin, xmax, ymin, ymax = pillars_grid.extent
    feasible_count = infeasible_count = 0
    for _ in range(300):
        # Nodes all over the map, some next to its border, pillars and wall stub.
        p0 = rng.uniform([xmin + 0.1, ymin + 0.1], [xmax - 0.1, ymax - 0.1])
        v0 = rng.uniform(-params.v_max, params.v_max, 2)
        with np.errstate(invalid="ignore"):
            children, feasible = prims.expand(*p0, *v0)
        ends, cost = children[:4], children[4]
        for row, (end_p, end_v, ok, reference_cost) in \
                enumerate(reference_children(pillars_grid, params, p0, v0)):
            np.testing.assert_allclose(ends[:2, row], end_p, rtol=0, atol=1e-12)
            np.testing.assert_allclose(ends[2:, row], end_v, rtol=0, atol=1e-12)
            assert feasible[row] == ok
            if ok:
                assert cost[row] == pytest.approx(reference_cost, rel=1e-12)
            feasible_count += ok
            infeasible_count += not ok
    assert feasible_count > 1000 and infeasible_count > 1000
