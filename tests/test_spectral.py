"""Tests for opnet.eigenbasis / opnet.Eigenbasis and the batched weights."""

from __future__ import annotations

import numpy as np
import potpourri3d as pp3d
import pytest
import trimesh

import opnet
from opnet import spectral
from opnet.data import toy
from opnet.mesh import unique_edges

_DENSE_FRACTION = getattr(spectral, "_DENSE_FRACTION", 0.3)

# ---------------------------------------------------------------------------------------------
# fixtures
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def sphere():
    tm = trimesh.creation.icosphere(2)  # 162 vertices: always the dense path
    return opnet.Mesh(tm.vertices, tm.faces)


@pytest.fixture(scope="module")
def capsule_default():
    return toy.capsule("default")  # ~1000 vertices: sparse (ARPACK) path for small k


@pytest.fixture(scope="module")
def capsule_quick():
    return toy.capsule("quick")  # rotationally symmetric: many (nearly) degenerate eigenvalue pairs


@pytest.fixture(scope="module")
def target():
    return toy.finger_pair("quick")[1]  # bent and bulged: no symmetry


@pytest.fixture(scope="module")
def full_target(target):
    return opnet.eigenbasis(target, target.n_vertices)


def dense_k(mesh):
    """The smallest k that takes the dense path on a mesh with >= 200 vertices."""
    k = int(np.ceil(_DENSE_FRACTION * mesh.n_vertices)) + 1
    assert not is_sparse_path(mesh, k)
    return k


def is_sparse_path(mesh, k):
    return not (k >= _DENSE_FRACTION * mesh.n_vertices or mesh.n_vertices < 200)


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------


def a_orthonormality_error(basis):
    G = basis.evecs.T @ (basis.mass[:, None] * basis.evecs)
    return np.abs(G - np.eye(basis.k)).max()


def eigen_residual(basis):
    """max over columns of ||A⁻¹WΦ − ΦΛ||_A, relative to the largest eigenvalue."""
    W = basis.mesh.stiffness
    A = basis.mass
    R = (W @ basis.evecs) / A[:, None] - basis.evecs * basis.evals[None, :]
    col = np.sqrt((A[:, None] * R**2).sum(0))
    return col.max() / basis.evals.max()


def subspace_sine(phi1, phi2, mass):
    """sin of the largest principal angle between the spans of two A-orthonormal bases."""
    M = phi1.T @ (mass[:, None] * phi2)
    R = np.sqrt(mass)[:, None] * (phi2 - phi1 @ M)
    return np.linalg.norm(R, 2)


def gap_after(evals, k):
    """Relative gap between eigenvalue k-1 and k (0-based), i.e. after the first k."""
    return (evals[k] - evals[k - 1]) / evals[k]


def k_at_gap(evals, lo, hi):
    """The k in [lo, hi] (hi < len(evals)) after which the spectrum has its largest relative gap.

    The span of the first k eigenvectors is only well defined (and comparable between two
    solves) when eigenvalue k is clearly separated from eigenvalue k-1.
    """
    ks = np.arange(lo, hi + 1)
    k = int(ks[np.argmax([gap_after(evals, k) for k in ks])])
    assert gap_after(evals, k) > 1e-3, "test mesh has no spectral gap in range"
    return k


# ---------------------------------------------------------------------------------------------
# the eigenproblem itself
# ---------------------------------------------------------------------------------------------

CASES = [("sphere", 40), ("capsule_default", 30), ("target", 25), ("target", "dense")]


def _case_basis(request, name, k):
    mesh = request.getfixturevalue(name)
    if k == "dense":
        k = dense_k(mesh)
    return mesh, k, opnet.eigenbasis(mesh, k)


@pytest.mark.parametrize("name,k", CASES, ids=[f"{n}-k{k}" for n, k in CASES])
def test_generalized_eigen_equation(request, name, k):
    mesh, k, b = _case_basis(request, name, k)
    assert isinstance(b, opnet.Eigenbasis)
    assert b.k == k and b.evals.shape == (k,) and b.evecs.shape == (mesh.n_vertices, k)
    assert b.evals.dtype == np.float64 and b.evecs.dtype == np.float64
    assert b.mesh is mesh
    np.testing.assert_array_equal(b.mass, mesh.mass)
    assert eigen_residual(b) < 1e-9
    assert a_orthonormality_error(b) < 1e-10


@pytest.mark.parametrize("name,k", CASES, ids=[f"{n}-k{k}" for n, k in CASES])
def test_evals_ascending_first_zero_constant(request, name, k):
    mesh, k, b = _case_basis(request, name, k)
    assert b.evals[0] == 0.0
    assert (np.diff(b.evals) >= 0).all()
    assert (b.evals[1:] > 0).all()
    # the Fiedler value is clearly separated from 0 on a connected mesh
    assert b.evals[1] > 1e-6 * b.evals[-1]
    # first eigenvector is exactly constant, with unit A-norm
    assert np.ptp(b.evecs[:, 0]) == 0.0
    assert b.evecs[0, 0] == pytest.approx(1 / np.sqrt(mesh.area), rel=1e-14)


def test_sphere_spectrum_multiplicities(sphere):
    # On a sphere, eigenvalues l(l+1)/r² come in groups of 2l+1; check the first groups
    # (1, 3, 5) are nearly degenerate and near the continuous values for the unit sphere.
    b = opnet.eigenbasis(sphere, 9)
    np.testing.assert_allclose(b.evals[1:4], 2.0, rtol=0.05)
    np.testing.assert_allclose(b.evals[4:9], 6.0, rtol=0.05)
    assert np.ptp(b.evals[1:4]) < 1e-2 * b.evals[1]
    assert np.ptp(b.evals[4:9]) < 2e-2 * b.evals[4]


def test_sign_convention(capsule_default, full_target):
    for b in (opnet.eigenbasis(capsule_default, 30), full_target):
        for j in range(b.k):  # the first vertex whose |value| is (within 1e-6) the column's largest is positive
            col = b.evecs[:, j]
            first = next(i for i, x in enumerate(np.abs(col)) if x >= np.abs(col).max() * (1 - 1e-6))
            assert col[first] > 0


def test_eigenbasis_does_not_modify_mesh(target):
    v = target.vertices.copy()
    m = target.mass.copy()
    W = target.stiffness.toarray()
    opnet.eigenbasis(target, 10)
    np.testing.assert_array_equal(target.vertices, v)
    np.testing.assert_array_equal(target.mass, m)
    np.testing.assert_array_equal(target.stiffness.toarray(), W)


# ---------------------------------------------------------------------------------------------
# determinism
# ---------------------------------------------------------------------------------------------


def test_deterministic_sparse_path(capsule_default):
    assert capsule_default.n_vertices > 900
    assert is_sparse_path(capsule_default, 30)
    b1 = opnet.eigenbasis(capsule_default, 30)
    # a separately built Mesh (no cached operators) gives the same bits
    fresh = opnet.Mesh(capsule_default.vertices, capsule_default.faces)
    b2 = opnet.eigenbasis(fresh, 30)
    b3 = opnet.eigenbasis(capsule_default, 30)
    for b in (b2, b3):
        np.testing.assert_array_equal(b.evecs, b1.evecs)
        np.testing.assert_array_equal(b.evals, b1.evals)


def test_deterministic_dense_path(target):
    k = dense_k(target)
    b1 = opnet.eigenbasis(target, k)
    b2 = opnet.eigenbasis(opnet.Mesh(target.vertices, target.faces), k)
    np.testing.assert_array_equal(b1.evecs, b2.evecs)
    np.testing.assert_array_equal(b1.evals, b2.evals)


# ---------------------------------------------------------------------------------------------
# scale robustness
# ---------------------------------------------------------------------------------------------

SCALE_CASES = [
    ("capsule_quick", "sparse", 1e-3),
    ("capsule_quick", "sparse", 1e3),
    ("capsule_quick", "dense", 1e3),
    ("target", "sparse", 1e-3),
    ("target", "sparse", 1e3),
    ("target", "dense", 1e-3),
    ("target", "dense", 1e3),
]


@pytest.mark.parametrize("name,path,s", SCALE_CASES, ids=[f"{n}-{p}-s{s:g}" for n, p, s in SCALE_CASES])
def test_scale_robustness(request, name, path, s):
    mesh = request.getfixturevalue(name)
    scaled = opnet.Mesh(s * mesh.vertices, mesh.faces)
    kk = 30 if path == "sparse" else dense_k(mesh)
    assert is_sparse_path(mesh, kk) == (path == "sparse")
    b = opnet.eigenbasis(mesh, kk)
    bs = opnet.eigenbasis(scaled, kk)
    assert scaled.area == pytest.approx(s**2 * mesh.area, rel=1e-12)
    # eigenvalues scale as 1 / s²
    np.testing.assert_allclose(bs.evals[1:] * s**2, b.evals[1:], rtol=1e-8)
    assert bs.evals[0] == 0.0
    # still A-orthonormal and solving the scaled problem
    assert a_orthonormality_error(bs) < 1e-10
    assert eigen_residual(bs) < 1e-9
    # the first k eigenvectors span the same subspace; k is chosen after a spectral gap, so
    # the subspace is well defined even where pairs of eigenvalues (nearly) coincide
    k = k_at_gap(b.evals, kk // 2, kk - 2)
    sin = subspace_sine(b.evecs[:, :k], s * bs.evecs[:, :k], b.mass)
    assert sin < 1e-6
    # ... as do the A-orthogonal projectors P = Φ Φᵀ A (scale-free)
    P = b.evecs[:, :k] @ (b.evecs[:, :k].T * b.mass[None, :])
    Ps = bs.evecs[:, :k] @ (bs.evecs[:, :k].T * bs.mass[None, :])
    assert np.abs(P - Ps).max() < 1e-6 * np.abs(P).max()


@pytest.mark.parametrize("name", ["target", "capsule_quick"])
@pytest.mark.parametrize("s", [1e-3, 1e3])
def test_scale_keeps_simple_eigenvectors_and_signs(request, name, s):
    """Where an eigenvalue is simple (well separated from both neighbours) its eigenvector is
    unique up to sign, and the documented sign convention makes it unique: scaling the mesh
    must then give exactly Φ / s.

    The capsule is mirror-symmetric in z, so its z-odd eigenvectors attain their largest
    magnitude at two mirrored vertices with opposite signs; "largest entry positive" must
    not be decided by rounding noise between those two.
    """
    mesh = request.getfixturevalue(name)
    b = opnet.eigenbasis(mesh, 30)
    bs = opnet.eigenbasis(opnet.Mesh(s * mesh.vertices, mesh.faces), 30)
    ev = b.evals
    simple = [j for j in range(1, 29) if min(ev[j] - ev[j - 1], ev[j + 1] - ev[j]) > 1e-2 * ev[j]]
    assert len(simple) >= 3, "no simple eigenvalues to compare"
    np.testing.assert_allclose(s * bs.evecs[:, simple], b.evecs[:, simple], atol=1e-6 * np.abs(b.evecs).max())


# ---------------------------------------------------------------------------------------------
# sparse vs dense, full basis
# ---------------------------------------------------------------------------------------------


def test_sparse_and_dense_agree(target, full_target):
    kk = 40
    assert is_sparse_path(target, kk)
    bs = opnet.eigenbasis(target, kk)
    np.testing.assert_allclose(bs.evals[1:], full_target.evals[1:kk], rtol=1e-9)
    k = k_at_gap(full_target.evals, 20, kk - 2)
    assert subspace_sine(full_target.evecs[:, :k], bs.evecs[:, :k], bs.mass) < 1e-6


def test_sparse_and_dense_agree_symmetric_capsule(capsule_quick):
    k = 20
    assert is_sparse_path(capsule_quick, k)
    bs = opnet.eigenbasis(capsule_quick, k)
    bd = opnet.eigenbasis(capsule_quick, dense_k(capsule_quick))
    np.testing.assert_allclose(bs.evals[1:], bd.evals[1:k], rtol=1e-9)


def test_full_basis(target, full_target):
    n = target.n_vertices
    b = full_target
    assert b.evecs.shape == (n, n)
    assert eigen_residual(b) < 1e-9
    assert a_orthonormality_error(b) < 1e-9
    completeness = b.evecs @ (b.evecs.T * b.mass[None, :])  # Φ Φᵀ A
    np.testing.assert_allclose(completeness, np.eye(n), atol=1e-8)
    assert b.evals[0] == 0.0 and (b.evals[1:] > 0).all()


def test_full_basis_small_meshes(sphere):
    tet = opnet.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    for mesh in (tet, sphere):
        n = mesh.n_vertices
        b = opnet.eigenbasis(mesh, n)
        np.testing.assert_allclose(b.evecs @ (b.evecs.T * b.mass[None, :]), np.eye(n), atol=1e-9)
        assert eigen_residual(b) < 1e-9


# ---------------------------------------------------------------------------------------------
# argument checking
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("k", [0, -3, 163, 10_000, 2.5, 3.0, "5", None], ids=repr)
def test_bad_k(sphere, k):
    with pytest.raises(ValueError, match="k must be an integer"):
        opnet.eigenbasis(sphere, k)


def test_numpy_integer_k(sphere):
    b = opnet.eigenbasis(sphere, np.int64(7))
    assert b.k == 7 and isinstance(b.k, int)
    np.testing.assert_array_equal(b.evals, opnet.eigenbasis(sphere, 7).evals)


def test_array_instead_of_mesh(sphere):
    with pytest.raises(TypeError, match="opnet.Mesh"):
        opnet.eigenbasis(np.asarray(sphere.vertices), 5)
    with pytest.raises(TypeError, match="opnet.Mesh"):
        opnet.eigenbasis((sphere.vertices, sphere.faces), 5)


# ---------------------------------------------------------------------------------------------
# truncate / project
# ---------------------------------------------------------------------------------------------


def test_truncate(capsule_default):
    b = opnet.eigenbasis(capsule_default, 30)
    t = b.truncate(7)
    assert isinstance(t, opnet.Eigenbasis) and t.k == 7
    np.testing.assert_array_equal(t.evals, b.evals[:7])
    np.testing.assert_array_equal(t.evecs, b.evecs[:, :7])
    assert t.mass is b.mass and t.mesh is b.mesh
    assert b.truncate(30).k == 30
    for bad in (0, -1, 31):
        with pytest.raises(ValueError, match="k must be in"):
            b.truncate(bad)


def test_truncate_non_integer(capsule_default):
    b = opnet.eigenbasis(capsule_default, 30)
    with pytest.raises(ValueError, match="k must be"):
        b.truncate(2.5)


def test_project_constant(target):
    b = opnet.eigenbasis(target, 20)
    c = b.project(np.ones(target.n_vertices))
    expected = np.zeros(20)
    expected[0] = np.sqrt(target.area)
    np.testing.assert_allclose(c, expected, atol=1e-10 * np.sqrt(target.area))
    assert c[0] == pytest.approx(np.sqrt(target.area), rel=1e-13)


def test_project_eigenvectors_and_reconstruction(target):
    b = opnet.eigenbasis(target, 20)
    # projecting the basis onto itself gives the identity
    np.testing.assert_allclose(b.project(b.evecs), np.eye(20), atol=1e-10)
    # a function in the span is reconstructed exactly; (n, d) works column by column
    rng = np.random.default_rng(0)
    coeffs = rng.standard_normal((20, 3))
    f = b.evecs @ coeffs
    got = b.project(f)
    assert got.shape == (20, 3)
    np.testing.assert_allclose(got, coeffs, atol=1e-10)
    for j in range(3):
        np.testing.assert_allclose(b.project(f[:, j]), coeffs[:, j], atol=1e-10)
    # Φᵀ A f equals the explicit formula for an arbitrary function
    g = target.vertices[:, 2] ** 2
    np.testing.assert_allclose(b.project(g), b.evecs.T @ (target.mass * g), rtol=1e-12)


# ---------------------------------------------------------------------------------------------
# batched vertex areas / cotan weights vs potpourri3d
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def batch(capsule_quick):
    v = capsule_quick.vertices
    rng = np.random.default_rng(42)
    noisy = v + 0.01 * rng.standard_normal(v.shape)  # irregular angles, some obtuse
    shapes = [
        toy.bend(v, np.deg2rad(80)),
        2.5 * toy.bulge(v, 0.5),
        noisy,
    ]
    return np.stack(shapes), np.asarray(capsule_quick.faces)


def test_batched_vertex_areas_match_potpourri3d(batch):
    V, F = batch
    areas = opnet.vertex_areas(V, F)
    assert areas.shape == (3, V.shape[1])
    for b in range(3):
        ref = pp3d.vertex_areas(V[b], F)
        np.testing.assert_allclose(areas[b], ref, rtol=1e-11, atol=0)
        # single-shape call agrees with the batched one
        np.testing.assert_allclose(opnet.vertex_areas(V[b], F), areas[b], rtol=1e-14)
    # the three shapes really differ
    assert np.abs(areas[0] - areas[1]).max() > 1e-3 * areas[0].max()


def test_batched_cotan_weights_match_potpourri3d(batch):
    V, F = batch
    E = unique_edges(F)
    w = opnet.cotan_edge_weights(V, F)
    assert w.shape == (3, len(E))
    saw_negative = False
    for b in range(3):
        L = pp3d.cotan_laplacian(V[b], F).tocsr()
        ref = -np.asarray(L[E[:, 0], E[:, 1]]).ravel()
        np.testing.assert_allclose(w[b], ref, rtol=1e-9, atol=1e-12 * np.abs(ref).max())
        np.testing.assert_allclose(opnet.cotan_edge_weights(V[b], F), w[b], rtol=1e-14)
        saw_negative |= bool((ref < 0).any())
    assert saw_negative  # the noisy shape has obtuse configurations with negative weights


def test_cotan_weights_rebuild_stiffness(batch):
    V, F = batch
    E = unique_edges(F)
    w = opnet.cotan_edge_weights(V[2], F)
    n = V.shape[1]
    W = np.zeros((n, n))
    np.add.at(W, (E[:, 0], E[:, 1]), -w)
    np.add.at(W, (E[:, 1], E[:, 0]), -w)
    W[np.arange(n), np.arange(n)] = -W.sum(1)
    ref = opnet.Mesh(V[2], F).stiffness.toarray()
    np.testing.assert_allclose(W, ref, atol=1e-9 * np.abs(ref).max())


def test_batched_weights_open_mesh():
    """Boundary edges have a single opposite corner: w = cot(α)/2."""
    tm = trimesh.creation.icosphere(2)
    keep = tm.triangles_center[:, 2] < 0.5  # cut off a cap
    sub = trimesh.Trimesh(tm.vertices, tm.faces[keep], process=False)
    sub.remove_unreferenced_vertices()
    v0, F = np.array(sub.vertices), np.array(sub.faces)
    rng = np.random.default_rng(1)
    V = np.stack([v0, v0 * [1.0, 2.0, 0.5], v0 + 0.02 * rng.standard_normal(v0.shape)])
    E = unique_edges(F)
    w = opnet.cotan_edge_weights(V, F)
    a = opnet.vertex_areas(V, F)
    for b in range(3):
        ref = -np.asarray(pp3d.cotan_laplacian(V[b], F).tocsr()[E[:, 0], E[:, 1]]).ravel()
        np.testing.assert_allclose(w[b], ref, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(a[b], pp3d.vertex_areas(V[b], F), rtol=1e-11)


def test_arpack_failure_falls_back_to_the_dense_solver(monkeypatch):
    import scipy.sparse.linalg as sla

    mesh = opnet.data.toy.capsule("default")
    ref = opnet.eigenbasis(mesh, 20)

    calls = []

    def no_convergence(*args, **kwargs):
        calls.append(1)
        raise sla.ArpackNoConvergence("no convergence", np.zeros(0), np.zeros((0, 0)))

    monkeypatch.setattr(sla, "eigsh", no_convergence)
    b = opnet.eigenbasis(mesh, 20)
    assert calls == [1]  # the sparse solver was tried, then the dense one answered
    np.testing.assert_allclose(b.evals, ref.evals, rtol=1e-10, atol=1e-12)
