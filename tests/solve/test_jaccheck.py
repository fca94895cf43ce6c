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
