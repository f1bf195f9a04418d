"""Functoriality (eq. 5), multiplicative interpolation (eq. 6) and analogies."""

import numpy as np
import pytest
import scipy.linalg

import opnet


@pytest.fixture(scope="module")
def ops(base_basis, base, targets):
    """Per kind: the base's own difference and the three targets'."""
    return {kind: [opnet.shape_difference(base_basis, m, kind) for m in [base, *targets]] for kind in opnet.KINDS}


@pytest.mark.filterwarnings("ignore:The logm input matrix is exactly singular")
def test_plain_logm_is_dominated_by_the_kernel(ops):
    """Why interpolate() deflates the kernel: scipy's logm of D^C puts log(≈0) on the constant mode."""
    D = ops["conformal"][1]
    L, Q = opnet.log_difference(D)
    assert Q.shape == (D.shape[0], D.shape[0] - 1)  # the constant function is deflated
    assert np.abs(L).max() < 5
    assert np.abs(scipy.linalg.logm(D)).max() > 20


@pytest.mark.parametrize("kind", opnet.KINDS)
def test_interpolation_is_real_and_hits_the_endpoints(ops, kind):
    D0, D1 = ops[kind][1], ops[kind][3]
    path = opnet.interpolate(D0, D1, np.linspace(0, 1, 5))
    assert path.shape == (5, *D0.shape) and path.dtype == np.float64
    scale = np.abs(D1).max()
    np.testing.assert_allclose(path[0], D0, atol=1e-10 * scale)
    np.testing.assert_allclose(path[-1], D1, atol=1e-10 * scale)
    # the multiplicative midpoint differs from the linear one
    assert np.abs(path[2] - opnet.interpolate(D0, D1, 0.5, scheme="linear")).max() > 1e-6 * scale


def test_linear_scheme_is_linear(ops):
    D0, D1 = ops["area"][1], ops["area"][2]
    np.testing.assert_allclose(opnet.interpolate(D0, D1, 0.3, scheme="linear"), 0.7 * D0 + 0.3 * D1)


def test_multiplicative_area_interpolation_is_a_geometric_mean_of_areas(small_shapes):
    """With a full basis, D^A_i = Φᵀ diag(a_i) Φ are simultaneously similar to diag(a_i / a_0), so eq. 6
    gives exactly the area ratios (a_1/a_0)^(1-t) (a_2/a_0)^t."""
    base, targets = small_shapes
    full_basis = opnet.eigenbasis(base, base.n_vertices)
    D1, D2 = (opnet.shape_difference(full_basis, t, "area") for t in targets[:2])
    a0, a1, a2 = full_basis.mass, targets[0].mass, targets[1].mass
    t = 0.3
    expected = full_basis.evecs.T @ ((a0 * (a1 / a0) ** (1 - t) * (a2 / a0) ** t)[:, None] * full_basis.evecs)
    np.testing.assert_allclose(opnet.interpolate(D1, D2, t), expected, atol=1e-8)


def test_analogy_identities(ops):
    for kind in opnet.KINDS:
        _, DA, DB, DC = ops[kind]
        scale = np.abs(DB).max()
        np.testing.assert_allclose(opnet.analogy(DA, DB, DA), DB, atol=1e-8 * scale)  # A:B :: A:B
        np.testing.assert_allclose(opnet.analogy(DA, DA, DC), DC, atol=1e-8 * scale)  # A:A :: C:C
    # the order of D_C D_A⁺ D_B matters: truncated operators do not commute
    _, DA, DB, DC = ops["conformal"]
    assert np.abs(opnet.analogy(DA, DB, DC) - opnet.analogy(DA, DC, DB)).max() > 1e-4 * np.abs(DB).max()


def test_area_analogy_multiplies_area_ratios(small_shapes):
    """D_X = D_C D_A⁺ D_B is the shape whose vertex areas are a_C a_B / a_A (full basis, exact)."""
    base, targets = small_shapes
    full_basis = opnet.eigenbasis(base, base.n_vertices)
    DA, DB, DC = (opnet.shape_difference(full_basis, t, "area") for t in targets)
    aA, aB, aC = (t.mass for t in targets)
    expected = full_basis.evecs.T @ ((aC * aB / aA)[:, None] * full_basis.evecs)
    np.testing.assert_allclose(opnet.analogy(DA, DB, DC), expected, atol=1e-8)


@pytest.mark.parametrize("kind", ["area", "conformal"])
def test_functoriality_with_full_bases(small_shapes, kind):
    """Eq. 5: C_0i D_0i⁺ D_0j C_0i⁻¹ equals the difference of S_j computed with S_i as the base.

    The conformal (H¹) inner product does not see constants, so there the identity holds
    modulo the constant function: row 0 (the constant component of the output) is free.
    """
    base, (Si, Sj, _) = small_shapes
    b0 = opnet.eigenbasis(base, base.n_vertices)
    bi = opnet.eigenbasis(Si, Si.n_vertices)
    C0i = opnet.identity_fmap(b0, bi)
    D0i, D0j = (opnet.shape_difference(b0, S, kind) for S in (Si, Sj))
    direct = opnet.shape_difference(bi, Sj, kind)
    got = opnet.relative_difference(D0i, D0j, C0i)
    rows = slice(0, None) if kind == "area" else slice(1, None)
    np.testing.assert_allclose(got[rows], direct[rows], atol=1e-7 * np.abs(direct).max())


def test_algebra_input_errors(ops):
    D = ops["area"][1]
    with pytest.raises(ValueError, match="linear"):
        opnet.interpolate(-D, D, 0.5)
    with pytest.raises(ValueError, match="scheme"):
        opnet.interpolate(D, D, 0.5, scheme="geodesic")
    with pytest.raises(ValueError, match="square"):
        opnet.analogy(D[:, :3], D, D)
    with pytest.raises(ValueError, match="same shape"):
        opnet.interpolate(D, D[:5, :5], 0.5)
    with pytest.raises(ValueError, match="NaN"):
        opnet.interpolate(D * np.nan, D, 0.5)


def _spd_power(S, p):
    w, U = np.linalg.eigh(0.5 * (S + S.T))
    return (U * w**p) @ U.T


@pytest.mark.parametrize("kind", ["conformal", "extrinsic"])
def test_interpolation_matches_the_symmetric_form(base, base_basis, targets, kind):
    """Independent check of eq. 6 on the non-constant block: with S = K0^{-1/2} M K0^{-1/2} (SPD),
    D(t) = K0^{-1/2} exp((1-t) log S0 + t log S1) K0^{1/2}."""
    ip = opnet.get_inner_product(kind)
    K0 = ip.project(base.vertices, base.faces, base_basis.evecs)[1:, 1:]
    Ms = [ip.project(t.vertices, t.faces, base_basis.evecs)[1:, 1:] for t in targets[:2]]
    Kih, Kh = _spd_power(K0, -0.5), _spd_power(K0, 0.5)
    logS = [scipy.linalg.logm(Kih @ M @ Kih).real for M in Ms]
    t = 0.35
    expected = Kih @ scipy.linalg.expm((1 - t) * logS[0] + t * logS[1]) @ Kh
    D0, D1 = (opnet.shape_difference(base_basis, m, kind) for m in targets[:2])
    got = opnet.interpolate(D0, D1, t)
    np.testing.assert_allclose(got[1:, 1:], expected, atol=1e-9 * np.abs(expected).max())
    assert np.abs(got[0]).max() < 1e-10 and np.abs(got[:, 0]).max() < 1e-10


@pytest.mark.parametrize("kind", opnet.KINDS)
def test_interpolation_with_an_imperfect_functional_map(base_basis, targets, kind):
    """Computed maps do not send constants exactly to constants: D e_0 != 0. Still real and exact at the ends."""
    tb = opnet.eigenbasis(targets[1], 60)
    exact = opnet.identity_fmap(base_basis, tb)
    noisy = opnet.FunctionalMap(
        exact.matrix + 1e-3 * np.random.default_rng(0).normal(size=exact.matrix.shape), base_basis, tb
    )
    D0 = opnet.shape_difference(base_basis, targets[0], kind)
    D1 = opnet.shape_difference(base_basis, targets[1], kind, fmap=noisy)
    path = opnet.interpolate(D0, D1, [0.0, 0.5, 1.0])
    scale = np.abs(D1).max()
    np.testing.assert_allclose(path[0], D0, atol=1e-9 * scale)
    np.testing.assert_allclose(path[2], D1, atol=1e-9 * scale)
    L, _ = opnet.log_difference(D1)
    assert np.abs(L).max() < 5  # no log(≈0) blow-up


def test_one_function_bases_are_handled():
    zero = np.zeros((1, 1))
    np.testing.assert_array_equal(opnet.interpolate(zero, zero, 0.5), zero)
    with pytest.raises(ValueError, match="zero"):
        opnet.log_difference(zero)


def test_analogy_is_the_papers_product_in_the_papers_order():
    """Section 7: D_X = D_C D_A⁺ D_B. On operators that do not commute, the other order D_B D_A⁺ D_C is another
    operator, so a swapped product fails here (the identities above hold for both orders)."""
    rng = np.random.default_rng(3)
    DA, DB, DC = (M @ M.T + np.eye(6) for M in rng.normal(size=(3, 6, 6)))  # symmetric positive definite
    paper = DC @ np.linalg.inv(DA) @ DB
    swapped = DB @ np.linalg.inv(DA) @ DC
    assert np.abs(paper - swapped).max() > 0.1 * np.abs(paper).max()  # the orders differ on these
    np.testing.assert_allclose(opnet.analogy(DA, DB, DC), paper, rtol=1e-10, atol=1e-10 * np.abs(paper).max())
