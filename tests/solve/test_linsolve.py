"""Every linear solver gives the same step; non-PD matrices raise; CHOLMOD analyses once; Schur."""

import numpy as np
import pytest
import scipy.sparse as sp

from legplan.solve import (CholmodSolver, NotPositiveDefiniteError, SchurSolver, make_solver)
from legplan.solve.linsolve import natural_order_suffices
import testproblems as tp


def _spd(n=40, seed=0):
    rng = np.random.default_rng(seed)
    J = sp.random(3 * n, n, density=0.1, random_state=rng) + sp.eye(3 * n, n)
    return sp.csc_matrix(J.T @ J), rng.standard_normal(n)


@pytest.mark.parametrize("name", ["cholmod", "scipy", "dense"])
def test_solvers_agree_with_dense_reference(name):
    H, b = _spd()
    for beta in (0.0, 0.3, 10.0):
        solver = make_solver(name)
        solver.factorize(H, beta)
        expected = np.linalg.solve(H.toarray() + beta * np.eye(H.shape[0]), b)
        np.testing.assert_allclose(solver.solve(b), expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("mode", ["simplicial", "supernodal"])
def test_cholmod_modes_agree(mode):
    H, b = _spd(80)
    solver = CholmodSolver(mode=mode)
    solver.factorize(H, 0.5)
    np.testing.assert_allclose(solver.solve(b), np.linalg.solve(H.toarray() + 0.5 * np.eye(80), b), rtol=1e-9)


@pytest.mark.parametrize("name", ["cholmod", "scipy", "dense"])
def test_indefinite_matrix_raises_not_positive_definite(name):
    H, _ = _spd()
    indefinite = sp.csc_matrix(H - 1e3 * sp.eye(H.shape[0]))
    solver = make_solver(name)
    with pytest.raises(NotPositiveDefiniteError):
        solver.factorize(indefinite, 0.0)
    solver.factorize(indefinite, 2e3)  # enough damping makes it positive definite again


def test_supernodal_indefinite_raises():
    H, _ = _spd()
    with pytest.raises(NotPositiveDefiniteError):
        CholmodSolver(mode="supernodal").factorize(sp.csc_matrix(H - 1e3 * sp.eye(H.shape[0])), 0.0)


def test_cholmod_analyses_once_per_pattern():
    H, b = _spd()
    solver = CholmodSolver()
    for beta in (1.0, 0.1, 0.01):
        solver.factorize(H, beta)
    H2 = H.copy()
    H2.data *= 2.0
    solver.factorize(H2, 1.0)
    assert solver.analyses == 1
    solver.factorize(sp.csc_matrix(H + sp.eye(H.shape[0], k=5) + sp.eye(H.shape[0], k=-5)) + 10 * sp.eye(40), 1.0)
    assert solver.analyses == 2


def test_unknown_solver_name():
    with pytest.raises(ValueError, match="linear solver"):
        make_solver("pardiso")


@pytest.mark.parametrize("dense_limit", [0, 10**7])
@pytest.mark.parametrize("inner", ["cholmod", "scipy", "dense"])
def test_schur_elimination_equals_full_solve(inner, dense_limit):
    problem = tp.bundle_adjustment_like(num_poses=4, num_landmarks=15)
    ne = problem.normal_equations(problem.layout.initial())
    eliminate, block = problem.layout.schur_columns()
    for beta in (0.0, 1e-3, 1.0):
        full = make_solver("dense")
        full.factorize(ne.hessian, beta)
        schur = SchurSolver(make_solver(inner), eliminate, block, dense_limit=dense_limit)
        schur.factorize(ne.hessian, beta)
        np.testing.assert_allclose(schur.solve(ne.gradient), full.solve(ne.gradient), rtol=1e-7, atol=1e-10)


def test_schur_rejects_coupled_eliminated_variables():
    H, _ = _spd(12)
    with pytest.raises(ValueError, match="not block-diagonal"):
        SchurSolver(make_solver("dense"), np.arange(6), 2).factorize(H, 0.0)


@pytest.mark.parametrize("name", ["cholmod", "scipy", "dense"])
def test_refactor_at_new_beta_equals_fresh_factorisation(name):
    H, b = _spd()
    reused = make_solver(name)
    reused.set_matrix(H)
    for beta in (1e-3, 0.3, 10.0):
        reused.refactor(beta)
        fresh = make_solver(name)
        fresh.factorize(H, beta)
        np.testing.assert_allclose(reused.solve(b), fresh.solve(b), rtol=1e-12, atol=1e-14)


def _schur_reference(H, rhs, eliminate, m, beta):
    """Schur complement with explicit per-block inverses (D_k + βI)⁻¹, the textbook form."""
    H = H.toarray()
    keep = np.setdiff1d(np.arange(H.shape[0]), eliminate)
    A, B = H[np.ix_(keep, keep)], H[np.ix_(keep, eliminate)]
    D = H[np.ix_(eliminate, eliminate)] + beta * np.eye(eliminate.size)
    count = eliminate.size // m
    Dinv = np.zeros_like(D)
    for k in range(count):
        sl = slice(k * m, (k + 1) * m)
        Dinv[sl, sl] = np.linalg.inv(D[sl, sl])
    xk = np.linalg.solve(A + beta * np.eye(keep.size) - B @ Dinv @ B.T, rhs[keep] - B @ Dinv @ rhs[eliminate])
    x = np.empty_like(rhs)
    x[keep] = xk
    x[eliminate] = Dinv @ (rhs[eliminate] - B.T @ xk)
    return x


@pytest.mark.parametrize("dense_limit", [0, 10**7])
def test_schur_eigenbasis_refactor_matches_explicit_block_inverses(dense_limit):
    problem = tp.step_planner_like(num_samples=12, degree=4, dim=5, slack_dim=3, num_clearance=4, epsilon=0.05)
    theta = problem.layout.initial() + 0.2 * np.random.default_rng(1).standard_normal(problem.layout.n)
    ne = problem.normal_equations(theta)
    eliminate, block = problem.layout.schur_columns()
    schur = SchurSolver(make_solver("cholmod"), eliminate, block, dense_limit=dense_limit)
    schur.set_matrix(ne.hessian)
    # one set_matrix, several λ as after rejected LM steps; at β = 1e-6 cond(H + βI) ≈ 5e6
    for beta, rtol in ((1e-6, 1e-8), (1e-2, 1e-10), (1.0, 1e-10), (1.5e3, 1e-10)):
        schur.refactor(beta)
        np.testing.assert_allclose(schur.solve(ne.gradient),
                                   _schur_reference(ne.hessian, ne.gradient, eliminate, block, beta),
                                   rtol=rtol, atol=1e-12)


def test_schur_refactor_raises_on_indefinite_eliminated_block():
    H = sp.csc_matrix(np.diag([4.0, 4.0, -1.0, 2.0]) + np.diag([0.5, 0.0, 0.0], 1) + np.diag([0.5, 0.0, 0.0], -1))
    schur = SchurSolver(make_solver("dense"), np.array([2, 3]), 2)
    schur.set_matrix(H)
    with pytest.raises(NotPositiveDefiniteError):
        schur.refactor(0.5)
    schur.refactor(2.0)  # −1 + 2 > 0: positive definite again
    np.testing.assert_allclose(schur.solve(np.ones(4)), np.linalg.solve(H.toarray() + 2 * np.eye(4), np.ones(4)),
                               rtol=1e-12)


def test_natural_order_only_where_it_is_provably_near_optimal():
    n = 200
    band = sp.diags([np.ones(n - 2), np.ones(n - 1), 4 * np.ones(n), np.ones(n - 1), np.ones(n - 2)],
                    [-2, -1, 0, 1, 2], format="csc")
    arrow = sp.lil_matrix((n, n))
    arrow.setdiag(2.0 * n)
    arrow[0, :] = arrow[:, 0] = 1.0
    arrow[0, 0] = 2.0 * n
    shuffle = np.random.default_rng(0).permutation(n)
    assert natural_order_suffices(band)
    unsorted = band.copy()  # every column's row indices reversed
    reverse = np.concatenate([np.arange(a, b)[::-1] for a, b in zip(band.indptr[:-1], band.indptr[1:])])
    unsorted.indices, unsorted.data = band.indices[reverse], band.data[reverse]
    unsorted.has_sorted_indices = False
    assert natural_order_suffices(unsorted)
    assert natural_order_suffices(sp.csc_matrix(arrow)[::-1, ::-1].tocsc())  # dense last row: no fill
    assert natural_order_suffices(sp.csc_matrix(np.ones((30, 30))))  # dense: every order fills it
    assert not natural_order_suffices(sp.csc_matrix(band[shuffle][:, shuffle]))
    assert not natural_order_suffices(sp.csc_matrix(arrow))  # dense first row: natural order fills L
    assert not natural_order_suffices(sp.csc_matrix(sp.tril(band)))  # one triangle: not judged


@pytest.mark.parametrize("H", [sp.diags([np.ones(99), 3 * np.ones(100), np.ones(99)], [-1, 0, 1], format="csc"),
                               _spd(60)[0]])
def test_auto_ordering_solves_like_cholmods_default_ordering(H):
    b = np.random.default_rng(2).standard_normal(H.shape[0])
    for beta in (1e-3, 1.0):
        auto, default = CholmodSolver(), CholmodSolver(ordering_method="default")
        auto.factorize(H, beta)
        default.factorize(H, beta)
        np.testing.assert_allclose(auto.solve(b), default.solve(b), rtol=1e-12)
        np.testing.assert_allclose(auto.solve(b), np.linalg.solve(H.toarray() + beta * np.eye(H.shape[0]), b),
                                   rtol=1e-10)


@pytest.mark.parametrize("name", ["cholmod", "scipy", "dense"])
def test_set_jacobian_factorises_jtj_plus_beta(name):
    rng = np.random.default_rng(4)
    J = sp.csr_matrix(sp.random(90, 30, density=0.1, random_state=rng) + sp.eye(90, 30))
    b = rng.standard_normal(30)
    solver = make_solver(name)
    solver.set_jacobian(J)
    for beta in (1e-3, 1.0):
        solver.refactor(beta)
        np.testing.assert_allclose(solver.solve(b), np.linalg.solve((J.T @ J).toarray() + beta * np.eye(30), b),
                                   rtol=1e-9)


@pytest.mark.parametrize("name", ["cholmod", "scipy", "dense"])
@pytest.mark.parametrize("seed", range(6))
def test_set_jacobian_rows_factorises_the_rows_product_on_one_analysis(name, seed):
    """Any subset of J's rows (the hinged LM's plain and active rows): the product of those rows
    only, and CHOLMOD keeps the one analysis of the whole J's pattern."""
    rng = np.random.default_rng(seed)
    J = sp.csr_matrix(sp.random(120, 40, density=0.08, random_state=rng))
    b = rng.standard_normal(40)
    solver = make_solver(name)
    for fraction in (1.0, 0.7, 0.3, 0.0):
        rows = np.flatnonzero(rng.random(120) < fraction)
        solver.set_jacobian(J, rows)
        Jr = J[rows].toarray()
        for beta in (1e-4, 1.0):
            solver.refactor(beta)
            np.testing.assert_allclose(solver.solve(b), np.linalg.solve(Jr.T @ Jr + beta * np.eye(40), b), rtol=1e-8)
    if name == "cholmod":
        assert solver.analyses == 1


def test_cholmod_analyses_the_jacobian_once_per_pattern_and_apart_from_h():
    J = sp.csr_matrix(sp.random(90, 30, density=0.1, random_state=np.random.default_rng(5)) + sp.eye(90, 30))
    solver = CholmodSolver()
    for scale in (1.0, 2.0):
        solver.set_jacobian(J * scale)
        solver.refactor(0.5)
    assert solver.analyses == 1
    H = sp.csc_matrix(J.T @ J)
    solver.set_matrix(H)  # same n, but H instead of Jᵀ: a new analysis
    solver.refactor(0.5)
    assert solver.analyses == 2
    b = np.ones(30)
    np.testing.assert_allclose(solver.solve(b), np.linalg.solve(H.toarray() + 0.5 * np.eye(30), b), rtol=1e-9)


def test_solvers_of_one_pattern_share_its_analysis_but_not_their_factors(monkeypatch):
    import legplan.solve.linsolve as linsolve

    monkeypatch.setattr(linsolve, "ANALYSES", linsolve.AnalysisCache(size=2))
    analysed = []
    analyze = linsolve.CholmodSolver._analyze
    monkeypatch.setattr(linsolve.CholmodSolver, "_analyze", lambda self, *a: analysed.append(1) or analyze(self, *a))
    H, b = _spd(seed=3)
    first, second = CholmodSolver(), CholmodSolver()
    first.factorize(H, 1.0)
    second.factorize(H * 3.0, 0.5)  # same pattern: the cached analysis, its own numeric factor
    assert len(analysed) == 1
    for solver, M, beta in ((first, H, 1.0), (second, H * 3.0, 0.5)):
        np.testing.assert_allclose(solver.solve(b), np.linalg.solve(M.toarray() + beta * np.eye(40), b), rtol=1e-10)
    for n in (41, 42):  # two other patterns push H's out of a cache of two
        CholmodSolver().factorize(_spd(n, seed=4)[0], 1.0)
    CholmodSolver().factorize(H, 1.0)
    assert len(analysed) == 4


@pytest.mark.parametrize("seed", range(6))
def test_refactor_rows_updates_the_factor_as_rows_join_and_leave(seed):
    """A few rows joining and leaving: rank updates, the same solutions as a refactorisation; many:
    a refactorisation."""
    from legplan.solve.linsolve import UPDATE_ROWS

    rng = np.random.default_rng(seed)
    J = sp.csr_matrix(sp.random(400, 40, density=0.08, random_state=rng) + sp.eye(400, 40))
    b = rng.standard_normal(40)
    solver = CholmodSolver()
    rows = np.flatnonzero(rng.random(400) < 0.5)
    solver.set_jacobian(J, rows)
    beta = 10.0 ** rng.uniform(-8, 0)
    solver.refactor(beta)
    for changed, updates in ((3, 1), (UPDATE_ROWS, 2), (UPDATE_ROWS + 1, 2)):
        flip = rng.choice(400, changed, replace=False)
        member = np.isin(np.arange(400), rows)
        member[flip] = ~member[flip]
        rows = np.flatnonzero(member)
        solver.refactor_rows(J, rows)
        assert solver.updates == updates
        Jr = J[rows].toarray()
        np.testing.assert_allclose(solver.solve(b), np.linalg.solve(Jr.T @ Jr + beta * np.eye(40), b), rtol=1e-8)


def test_jacobians_that_differ_by_repeated_row_patterns_share_one_analysis(monkeypatch):
    """JᵀJ has the pattern of J's distinct row patterns: J with more rows repeating them (another
    task's extra samples) takes the cached analysis, and solves its own system."""
    import legplan.solve.linsolve as linsolve

    monkeypatch.setattr(linsolve, "ANALYSES", linsolve.AnalysisCache())
    rng = np.random.default_rng(7)
    J = sp.csr_matrix(sp.random(150, 30, density=0.1, random_state=rng) + sp.eye(150, 30))
    repeats = J[rng.integers(0, 150, 60)].copy()
    repeats.data = rng.standard_normal(repeats.nnz)
    longer = sp.csr_matrix(sp.vstack([repeats[:30], J, repeats[30:]]))
    first, second = CholmodSolver(ordering_method="default"), CholmodSolver(ordering_method="default")
    first.set_jacobian(J)
    analysed = []
    analyze = linsolve.CholmodSolver._analyze
    monkeypatch.setattr(linsolve.CholmodSolver, "_analyze", lambda self, *a: analysed.append(1) or analyze(self, *a))
    second.set_jacobian(longer)
    assert analysed == []
    b = rng.standard_normal(30)
    second.refactor(1e-3)
    np.testing.assert_allclose(second.solve(b), np.linalg.solve((longer.T @ longer).toarray() + 1e-3 * np.eye(30), b),
                               rtol=1e-9)
    other = sp.csr_matrix(sp.vstack([J, sp.csr_matrix(np.ones((1, 30)))]))  # a new row pattern: a new analysis
    CholmodSolver(ordering_method="default").set_jacobian(other)
    assert analysed == [1]


def test_canonical_form_falls_back_to_the_whole_pattern_when_hashes_collide(monkeypatch):
    import legplan.solve.linsolve as linsolve

    J = sp.csr_matrix(sp.random(40, 12, density=0.2, random_state=np.random.default_rng(8)) + sp.eye(40, 12))
    A = linsolve._transposed(J)
    assert linsolve._canonical(A).shape[1] < A.shape[1]  # repeated patterns (the identity's empty rows)
    monkeypatch.setattr(linsolve, "_column_weights", lambda n: np.zeros(n, np.uint64))  # every hash equal
    assert linsolve._canonical(A) is A


def test_rows_given_twice_count_twice_in_set_jacobian_and_refactor_rows():
    """Sorted rows with repeats (a two-sided constraint row active on both sides, `Problem.row_map`):
    J_RᵀJ_R counts a repeated row twice, through `set_jacobian` and through `refactor_rows` (which
    refactorizes when either set repeats a row), on the analysis of the whole J."""
    rng = np.random.default_rng(7)
    J = sp.csr_matrix(sp.random(60, 12, density=0.2, random_state=rng) + sp.eye(60, 12))
    b = rng.standard_normal(12)
    beta = 1e-3
    solver = CholmodSolver()

    def expect(rows):
        Jr = J[rows].toarray()  # repeated rows stay repeated
        return np.linalg.solve(Jr.T @ Jr + beta * np.eye(12), b)

    rows = np.sort(np.r_[np.arange(0, 60, 2), [4, 10]])  # rows 4 and 10 twice
    solver.set_jacobian(J, rows)
    solver.refactor(beta)
    np.testing.assert_allclose(solver.solve(b), expect(rows), rtol=1e-9)
    for rows in (np.arange(0, 60, 3), np.sort(np.r_[np.arange(0, 60, 3), [9]]), np.arange(1, 60, 2)):
        solver.refactor_rows(J, rows)
        np.testing.assert_allclose(solver.solve(b), expect(rows), rtol=1e-9)


def test_rows_named_by_keys_follow_the_set_by_its_keys():
    """Residual rows that share rows of J (`keys` name them; a row of J under two keys counts
    twice): `refactor_rows` adds and removes by key, by rank updates when few change, and solves as
    the dense J_RᵀJ_R + βI of the rows in key order."""
    rng = np.random.default_rng(8)
    J = sp.csr_matrix(sp.random(40, 10, density=0.25, random_state=rng) + sp.eye(40, 10))
    jrow = np.r_[np.arange(40), np.arange(0, 40, 2)]  # keys 40.. stand for the even rows again
    b = rng.standard_normal(10)
    beta = 1e-2
    solver = CholmodSolver()

    def expect(keys):
        Jr = J[jrow[keys]].toarray()
        return np.linalg.solve(Jr.T @ Jr + beta * np.eye(10), b)

    keys = np.flatnonzero(rng.random(60) < 0.5)
    solver.set_jacobian(J, jrow[keys], keys)
    solver.refactor(beta)
    np.testing.assert_allclose(solver.solve(b), expect(keys), rtol=1e-9)
    for _ in range(4):
        member = np.isin(np.arange(60), keys)
        flip = rng.choice(60, 3, replace=False)
        member[flip] = ~member[flip]
        keys = np.flatnonzero(member)
        updates = solver.updates
        solver.refactor_rows(J, jrow[keys], keys)
        assert solver.updates == updates + 1  # three keys changed: rank updates
        np.testing.assert_allclose(solver.solve(b), expect(keys), rtol=1e-9)


def test_dense_solver_is_lapack_cholesky_as_scipy_calls_it():
    """The dense solver calls LAPACK's potrf/potrs itself: the factor and the solution are those of
    scipy.linalg.cho_factor/cho_solve bit for bit; a matrix that is not positive definite raises."""
    import scipy.linalg

    H, b = _spd(30, seed=4)
    dense = H.toarray()
    solver = make_solver("dense")
    for beta in (0.0, 1e-6, 2.5):
        solver.factorize(dense, beta)
        reference = scipy.linalg.cho_factor(dense + beta * np.eye(30), lower=True, check_finite=False)
        assert np.array_equal(np.tril(solver._factor), np.tril(reference[0]))
        assert np.array_equal(solver.solve(b), scipy.linalg.cho_solve(reference, b, check_finite=False))
    assert np.array_equal(dense, H.toarray())  # the matrix given is not modified
    with pytest.raises(NotPositiveDefiniteError):
        solver.factorize(dense, -2.0 * np.linalg.eigvalsh(dense).max())
    solver.factorize(np.zeros((0, 0)), 1.0)
    assert solver.solve(np.zeros(0)).shape == (0,)

def test_the_same_read_only_pattern_is_taken_without_a_look_and_a_changed_one_is_analysed():
    """`set_jacobian` of J's that share one read-only pattern (the reduced J of the hinged LM, from
    linearization to linearization) keeps the analysis and trusts the pattern's sorted indices; equal
    writeable arrays are compared and kept too; another pattern is analysed; every factorization
    solves JᵀJ + βI."""
    rng = np.random.default_rng(7)
    J = sp.csr_matrix(sp.random(80, 25, density=0.15, random_state=rng) + sp.eye(80, 25))
    indices, indptr = J.indices.copy(), J.indptr.copy()
    indices.flags.writeable = indptr.flags.writeable = False
    solver, b = CholmodSolver(), np.ones(25)

    def check(matrix):
        dense = matrix.toarray()
        np.testing.assert_allclose(solver.solve(b), np.linalg.solve(dense.T @ dense + 0.3 * np.eye(25), b), rtol=1e-9)

    for scale in (1.0, 3.0):
        matrix = sp.csr_matrix((J.data * scale, indices, indptr), shape=J.shape)
        solver.set_jacobian(matrix)
        solver.refactor(0.3)
        check(matrix)
    assert solver.analyses == 1
    equal = sp.csr_matrix((J.data * 2.0, J.indices.copy(), J.indptr.copy()), shape=J.shape)  # writeable, equal
    solver.set_jacobian(equal)
    solver.refactor(0.3)
    check(equal)
    assert solver.analyses == 1
    other = sp.csr_matrix(J + sp.csr_matrix(([1.0], ([0], [24])), shape=J.shape)) if J[0, 24] == 0 else J[1:]
    solver.set_jacobian(other)
    solver.refactor(0.3)
    check(other)
    assert solver.analyses == 2
