"""The finite-difference checker finds wrong Jacobians and accepts right ones."""

import numpy as np
import scipy.sparse as sp

from legplan.solve import FunctionBlock, check_jacobian, numeric_jacobian


def _block(bug=0.0):
    def fn(x, y):
        r = np.array([np.sin(x[0]) * y[0], x[1] ** 2 + y[0] * y[1]])
        jx = np.array([[np.cos(x[0]) * y[0], 0], [0, 2 * x[1] + bug]])
        jy = sp.csr_matrix(np.array([[np.sin(x[0]), 0], [y[1], y[0]]]))
        return r, [jx, jy]
    return FunctionBlock(["x", "y"], 2, fn)


def test_correct_block_passes_with_mapping_or_sequence():
    values = {"x": np.array([0.3, -1.2]), "y": np.array([2.0, 0.7])}
    for arg in (values, [values["x"], values["y"]]):
        report = check_jacobian(_block(), arg)
        assert report.max_abs_error < 1e-8 and report.ok()


def test_wrong_entry_is_located():
    report = check_jacobian(_block(bug=0.5), {"x": np.array([0.3, -1.2]), "y": np.array([2.0, 0.7])})
    assert report.max_abs_error > 0.4
    assert report.worst == ("x", 1, 1)
    assert not report.ok()


def test_plain_function_form():
    fn = lambda x: (np.array([x[0] * x[1], np.exp(x[1])]), np.array([[x[1], x[0]], [0, np.exp(x[1])]]))
    assert check_jacobian(fn, np.array([1.5, 0.2])).max_rel_error < 1e-7
    np.testing.assert_allclose(numeric_jacobian(lambda x: fn(x)[0], [1.5, 0.2]), fn(np.array([1.5, 0.2]))[1],
                               rtol=1e-8)


def _banded(missing=False):
    """A chain r_i = x_i² x_{i+1} (bidiagonal Jacobian); `missing` drops ∂r_2/∂x_3 from the analytic one."""
    def fn(x):
        r = x[:-1] ** 2 * x[1:]
        jac = sp.lil_matrix((x.size - 1, x.size))
        for i in range(x.size - 1):
            jac[i, i] = 2 * x[i] * x[i + 1]
            if not (missing and i == 2):
                jac[i, i + 1] = x[i] ** 2
        return r, jac.tocsr()
    return fn


def test_grouped_columns_share_no_row_and_give_the_same_jacobian():
    from legplan.solve.jaccheck import column_groups

    fn, x = _banded(), np.linspace(0.5, 2.0, 9)
    pattern = fn(x)[1].toarray() != 0
    groups = column_groups(pattern)
    assert len(groups) == 2 and sorted(np.concatenate(groups)) == list(range(9))
    assert all(pattern[:, g].sum(axis=1).max() <= 1 for g in groups)
    np.testing.assert_allclose(numeric_jacobian(lambda v: fn(v)[0], x, pattern=pattern),
                               numeric_jacobian(lambda v: fn(v)[0], x), rtol=1e-9, atol=1e-12)


def test_a_derivative_missing_from_the_pattern_still_fails_the_check():
    """Grouping by the analytic pattern must not hide an entry the analytic Jacobian lacks."""
    fn, x = _banded(missing=True), np.linspace(0.5, 2.0, 9)
    block = FunctionBlock(["x"], 8, lambda v: (fn(v)[0], [fn(v)[1]]))
    report = check_jacobian(block, [x])
    assert not report.ok() and report.worst[1] == 2
    assert report.max_abs_error > 0.5 * x[2] ** 2
