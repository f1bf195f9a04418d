"""Theorem 1 (Gram recovery) and the metrics of section 6 (eq. 9, d_V, d_E)."""

import numpy as np
import pytest
from scipy.linalg import orthogonal_procrustes
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

import opnet


def orthogonal_residual(Y, X):
    """Max error of Y against X after the best orthogonal map (reflections allowed)."""
    Q, _ = orthogonal_procrustes(Y, X)
    return np.abs(Y @ Q - X).max()


def test_full_basis_recovery_is_exact(full_basis, targets):
    X = targets[2].vertices
    Y = opnet.recover_embedding(opnet.gram_matrix(full_basis, X), full_basis)
    assert orthogonal_residual(Y, X) < 1e-8


def test_truncated_recovery_is_the_projection_and_improves_with_k(base, full_basis):
    X = base.vertices
    errors = []
    for k in (10, 60, 200):
        b = full_basis.truncate(k)
        Y = opnet.recover_embedding(opnet.gram_matrix(b, X), b)
        proj = b.evecs @ b.project(X)  # Φ Φᵀ A X
        assert orthogonal_residual(Y, proj) < 1e-8 * np.abs(X).max()
        errors.append(np.abs(Y @ orthogonal_procrustes(Y, X)[0] - X).max())
    assert errors[0] > errors[1] > errors[2]


def test_gram_is_rotation_invariant_and_rank_three(base_basis, base):
    R = Rotation.random(random_state=4).as_matrix()
    G = opnet.gram_matrix(base_basis, base.vertices)
    np.testing.assert_allclose(opnet.gram_matrix(base_basis, base.vertices @ R.T), G, atol=1e-12 * np.abs(G).max())
    assert np.linalg.matrix_rank(G, tol=1e-10 * np.abs(G).max()) == 3
    with pytest.raises(ValueError, match="match the basis"):
        opnet.recover_embedding(G[:5, :5], base_basis)


def test_kabsch_recovers_a_rotation_without_reflection(base):
    X = base.vertices
    R0 = Rotation.random(random_state=2).as_matrix()
    R, t = opnet.kabsch(X, X @ R0.T + 1.5)
    np.testing.assert_allclose(R, R0, atol=1e-12)
    np.testing.assert_allclose(t, 1.5 * np.ones(3) - 0 * t, atol=1e-12)
    mirrored = X * np.array([-1.0, 1.0, 1.0])
    R, _ = opnet.kabsch(X, mirrored)
    assert np.isclose(np.linalg.det(R), 1.0)
    assert opnet.d_R(mirrored, X) > 1e-3  # a reflection is not a rigid motion


def test_d_R_is_the_minimum_over_rigid_motions(targets):
    X, Y = targets[0].vertices, targets[1].vertices

    def loss(p):
        R = Rotation.from_rotvec(p[:3]).as_matrix()
        return np.mean(np.sum((Y @ R.T + p[3:] - X) ** 2, axis=1))

    brute = min(
        minimize(loss, np.r_[Rotation.random(random_state=s).as_rotvec(), 0, 0, 0], method="Powell").fun
        for s in range(6)
    )
    assert opnet.d_R(X, Y) <= brute + 1e-9
    assert opnet.d_R(X, Y) == pytest.approx(brute, rel=1e-3)


def test_metrics_vanish_on_rigid_motions_and_scale_as_expected(base):
    X, F = base.vertices, base.faces
    moved = X @ Rotation.random(random_state=0).as_matrix().T + 2.0
    assert opnet.d_R(X, moved) < 1e-20 and opnet.d_V(X, moved, F) < 1e-12 and opnet.d_E(X, moved, F) < 1e-12
    s = 1.1
    assert opnet.d_V(X, s * X, F) == pytest.approx(s**3 - 1)
    assert opnet.d_E(X, s * X, F) == pytest.approx(s - 1)
    batch = np.stack([X, s * X])
    np.testing.assert_allclose(opnet.d_E(batch, np.stack([s * X, X]), F), [s - 1, 1 - 1 / s])
    assert opnet.mesh_volume(X, F) > 0  # outward-oriented closed capsule


def test_volume_error_is_unsigned_and_needs_a_closed_mesh(base):
    X, F = base.vertices, base.faces
    assert opnet.d_V(X, X * [-1.0, 1.0, 1.0], F) < 1e-12  # a mirror image has the same volume
    assert opnet.d_V(X, X, F[:, ::-1]) < 1e-12  # so do inward-facing triangles
    with pytest.raises(ValueError, match="closed"):
        opnet.d_V(X, X + 1.0, F[1:])
    Y = X.copy()
    Y[F[0, 1]] = Y[F[0, 0]]
    with pytest.raises(ValueError, match="zero-length"):
        opnet.d_E(Y, X, F)
    with pytest.raises(ValueError, match="faces"):
        opnet.d_E(X, X, F + X.shape[0])


def test_gram_functions_check_their_arguments(base, base_basis):
    G = opnet.gram_matrix(base_basis, base.vertices)
    with pytest.raises(TypeError, match="Eigenbasis"):
        opnet.gram_matrix(base, base.vertices)
    with pytest.raises(TypeError, match="Eigenbasis"):
        opnet.recover_embedding(G, base_basis.evecs)
    for dim in (0, base_basis.k + 1):
        with pytest.raises(ValueError, match="dim"):
            opnet.recover_embedding(G, base_basis, dim=dim)
