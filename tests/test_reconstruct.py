"""Reconstruction by operator matching (opnet.reconstruct): the geometric baseline and refinement."""

import pytest

pytest.importorskip("torch")  # the net extra: skipped by a core-only install

import numpy as np
import torch
from tqdm.auto import tqdm

import opnet
from opnet.data import toy
from opnet.geometric import _adam, _lbfgs, reconstruct


@pytest.fixture(scope="module")
def problem(base_basis, targets):
    X = np.stack([t.vertices for t in targets[:2]])  # bend, bulge
    return X, opnet.shape_differences(base_basis, X)


def test_geometric_baseline_recovers_toy_shapes(base_basis, problem):
    X, ops = problem
    curves = []
    R = reconstruct(
        ops, base_basis, steps=60, smoothness=0.0, progress=False, callback=lambda step, Xs, m: curves.append(m.numpy())
    )
    assert R.shape == X.shape and R.dtype == np.float64 and np.isfinite(R).all()
    before = opnet.d_R(X, np.broadcast_to(base_basis.mesh.vertices, X.shape))
    after = opnet.d_R(X, R)
    # the bulge (an area change) is recovered almost exactly; the bend (nearly isometric) is harder
    assert after[1] < before[1] / 100 and after[0] < before[0] / 2, (before, after)
    assert np.allclose(curves[0], 3.0)  # relative mismatch: 1 per channel at the base
    assert np.all(curves[-1] < 0.1 * curves[0])
    assert np.all(np.diff(np.stack(curves), axis=0) <= 1e-9 + 1e-6 * np.stack(curves)[:-1])  # monotone (Armijo)


def test_shapes_are_independent_in_a_batch(base_basis, problem):
    X, ops = problem
    together = reconstruct(ops, base_basis, steps=15, progress=False)
    alone = np.concatenate([reconstruct(ops[i : i + 1], base_basis, steps=15, progress=False) for i in range(2)])
    assert np.allclose(together, alone, atol=1e-9)


def test_ground_truth_is_a_fixed_point_and_refinement_helps(base_basis, problem):
    X, ops = problem
    assert np.allclose(reconstruct(ops, base_basis, init=X, steps=5, progress=False), X, atol=1e-9)
    rng = np.random.default_rng(1)
    noisy = X + 0.01 * toy.bulge(X[0], 0.5)[None] * rng.standard_normal((1, 1, 3))
    refined = reconstruct(ops, base_basis, init=noisy, steps=40, smoothness=0.0, progress=False)
    assert np.all(opnet.d_R(X, refined) < opnet.d_R(X, noisy))


@pytest.mark.parametrize("minimise", [_adam, _lbfgs])
def test_a_diverging_step_never_reaches_the_result(minimise):
    """An objective that is NaN past a wall (like a collapsing triangle): the result is the best finite iterate."""

    def objective(X, rows=slice(None)):
        f = ((X - 3.0) ** 2).sum((-1, -2))
        f = torch.where(X[:, 0, 0] > 1.0, torch.full_like(f, float("nan")), f)
        return f, f

    start = torch.zeros(2, 4, 3, dtype=torch.float64)
    bar = tqdm(disable=True)
    if minimise is _adam:
        with pytest.warns(RuntimeWarning, match="NaN or infinite"):
            X = minimise(objective, start, 20, 0.7, None, bar)
    else:
        X = minimise(objective, start, 20, 1.0, None, bar)
    assert torch.isfinite(X).all() and (X[:, 0, 0] <= 1.0).all()
    assert (objective(X)[0] < objective(start)[0]).all()


def test_adam_lowers_the_error(base_basis, problem):
    X, ops = problem
    R = reconstruct(ops, base_basis, steps=30, optimizer="adam", lr=1e-2, smoothness=0.0, progress=False)
    assert np.all(opnet.d_R(X, R) < opnet.d_R(X, np.broadcast_to(base_basis.mesh.vertices, X.shape)))


def test_bad_input(base_basis, problem, small_shapes):
    X, ops = problem
    with pytest.raises(ValueError, match=r"\(B, 2, 30, 30\)"):
        reconstruct(ops, base_basis, channels="area,extrinsic", progress=False)
    with pytest.raises(ValueError, match="base basis they were computed with"):
        reconstruct(ops, base_basis.truncate(20), progress=False)
    other = opnet.eigenbasis(small_shapes[0], 30)  # a basis of another mesh
    with pytest.raises(ValueError, match="init must have shape"):
        reconstruct(ops, other, init=X, progress=False)
    bad = ops.copy()
    bad[0, 0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        reconstruct(bad, base_basis, progress=False)
    with pytest.raises(ValueError, match="empty"):
        reconstruct(ops[:0], base_basis, progress=False)
    with pytest.raises(ValueError, match="optimizer"):
        reconstruct(ops, base_basis, optimizer="sgd", progress=False)
    with pytest.raises(ValueError, match="init must be 'base'"):
        reconstruct(ops, base_basis, init="zeros", progress=False)
    with pytest.raises(ValueError, match="zero-area"):
        reconstruct(ops, base_basis, init=np.zeros_like(X), progress=False)
    with pytest.raises(ValueError, match="smoothness"):
        reconstruct(ops, base_basis, smoothness=-1, progress=False)
    # torch tensors are accepted as well as arrays
    R = reconstruct(torch.tensor(ops[:1]), base_basis, steps=2, progress=False)
    assert R.shape == (1, *X.shape[1:])


def test_public_name():
    import opnet.geometric

    assert opnet.reconstruct is opnet.geometric.reconstruct


def test_a_shape_already_matched_costs_nothing_and_does_not_break_the_batch(base_basis, problem):
    """Operators computed by torch_ops at the start: the gradient is exactly zero (no NaN step, no error)."""
    from opnet.torch_ops import ShapeDifferences

    X, _ = problem
    exact = ShapeDifferences(base_basis)(torch.tensor(X)).numpy()
    R = reconstruct(exact, base_basis, init=X, steps=3, progress=False)
    np.testing.assert_array_equal(R, X)
    base = base_basis.mesh.vertices
    at_base = ShapeDifferences(base_basis)(torch.tensor(base[None])).numpy()
    mixed = reconstruct(np.concatenate([at_base, exact[1:]]), base_basis, steps=3, progress=False)
    np.testing.assert_array_equal(mixed[0], base)  # the base matches its own operators: it stays
    assert np.isfinite(mixed).all()
    # numpy scalars and "auto" are accepted like elsewhere in opnet
    reconstruct(
        exact[:1],
        base_basis,
        init=X[:1],
        steps=1,
        smoothness=np.float32(1),
        lr=np.float64(1),
        device="auto",
        progress=False,
    )


def test_truncated_operators_are_exact_and_coarse_to_fine_runs(base_basis, problem):
    from opnet.geometric import truncate_operators

    X, ops = problem
    for m in (5, 12, 29):
        np.testing.assert_allclose(
            truncate_operators(ops, base_basis, opnet.KINDS, m),
            opnet.shape_differences(base_basis.truncate(m), X),
            atol=1e-10,
        )
    steps = []
    R = reconstruct(
        ops,
        base_basis,
        steps=10,
        coarse_to_fine=(10, 20),
        progress=False,
        callback=lambda step, Xs, m: steps.append(step),
    )
    assert steps == list(range(31))  # three stages of 10 steps, numbered on
    assert np.isfinite(R).all() and np.all(
        opnet.d_R(X, R) < opnet.d_R(X, np.broadcast_to(base_basis.mesh.vertices, X.shape))
    )
    for bad in ((20, 10), (0,), (30,), (10.5,)):
        with pytest.raises(ValueError, match="coarse_to_fine"):
            reconstruct(ops, base_basis, coarse_to_fine=bad, progress=False)


def _sphere_and_small_deformation():
    import trimesh

    s = trimesh.creation.icosphere(2)
    base = opnet.Mesh(s.vertices, s.faces)
    v = base.vertices
    return base, v * np.array([1.02, 0.99, 1.0]) + 0.02 * np.sin(3 * v[:, [1]]) * np.array([0.0, 0.0, 1.0])


def test_the_laplacian_of_edge_lengths_is_that_of_the_vertices():
    """lengths_laplacian (intrinsic: Heron and the law of cosines) agrees with the vertices' cotan Laplacian."""
    from opnet.geometric import lengths_laplacian
    from opnet.mesh import unique_edges
    from opnet.spectral import areas_and_cotan_weights

    base, target = _sphere_and_small_deformation()
    X = np.stack([base.vertices, target])
    e = unique_edges(base.faces)
    masses, weights = lengths_laplacian(torch.tensor(((X[:, e[:, 0]] - X[:, e[:, 1]]) ** 2).sum(-1)), base.faces)
    a, w = areas_and_cotan_weights(X, base.faces)
    assert np.allclose(masses.numpy(), a, rtol=1e-12, atol=0) and np.allclose(
        weights.numpy(), w, rtol=1e-10, atol=1e-14
    )
    # lengths that break a triangle inequality have no triangle: NaN, which the line search rejects
    bad = torch.tensor(((X[0, e[:, 0]] - X[0, e[:, 1]]) ** 2).sum(-1))
    bad[0] = 100.0
    assert torch.isnan(lengths_laplacian(bad, base.faces)[1]).any()


def test_shape_from_laplacian_recovers_a_small_deformation_up_to_a_rigid_motion():
    """Given the target's full Laplacian (its cotan weights and masses), SfL finds the target from the base, up to a
    rigid motion: the input is intrinsic, so a moved target gives the same result."""
    from opnet.geometric import shape_from_laplacian
    from opnet.spectral import areas_and_cotan_weights

    base, target = _sphere_and_small_deformation()
    R = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    targets = np.stack([target, target @ R.T + 0.5])
    masses, weights = areas_and_cotan_weights(targets, base.faces)
    X = shape_from_laplacian(weights, masses, base, progress=False)
    assert X.shape == targets.shape and X.dtype == np.float64
    before = opnet.d_R(targets, np.broadcast_to(base.vertices, targets.shape))
    assert np.all(opnet.d_R(targets, X) < 1e-10 * before), (opnet.d_R(targets, X), before)
    assert np.allclose(X[0], X[1], atol=1e-9)  # the same Laplacian, the same shape
    assert np.all(opnet.d_E(targets, X, base.faces) < 1e-8)


def test_shape_from_laplacian_refuses_what_it_cannot_use():
    from opnet.geometric import shape_from_laplacian
    from opnet.spectral import areas_and_cotan_weights

    base, target = _sphere_and_small_deformation()
    masses, weights = areas_and_cotan_weights(target, base.faces)
    with pytest.raises(ValueError, match="one cotan weight per edge of the base's triangulation"):
        shape_from_laplacian(weights[:-1], masses, base)
    with pytest.raises(ValueError, match="one lumped mass per base vertex"):
        shape_from_laplacian(weights, masses[:-1], base)
    with pytest.raises(ValueError, match="masses finite and positive"):
        shape_from_laplacian(weights, -masses, base)
    with pytest.raises(TypeError, match="opnet.Mesh or opnet.Eigenbasis"):
        shape_from_laplacian(weights, masses, base.vertices)
    with pytest.raises(ValueError, match="metric_steps must be a non-negative integer"):
        shape_from_laplacian(weights, masses, base, metric_steps=-1)


def test_the_jacobian_of_the_laplacian_of_lengths_is_its_derivative():
    """lengths_laplacian_jacobian (closed form) agrees with torch's derivative of lengths_laplacian."""
    from opnet.geometric import lengths_laplacian, lengths_laplacian_jacobian
    from opnet.mesh import unique_edges

    base, target = _sphere_and_small_deformation()
    e = unique_edges(base.faces)
    s = ((target[e[:, 0]] - target[e[:, 1]]) ** 2).sum(-1)
    J = lengths_laplacian_jacobian(s, base.faces, e, len(target)).toarray()

    def stacked(x):
        masses, weights = lengths_laplacian(x, base.faces)
        return torch.cat([weights, masses])

    dense = torch.autograd.functional.jacobian(stacked, torch.tensor(s)).numpy()
    assert J.shape == dense.shape and np.abs(J - dense).max() < 1e-9 * np.abs(dense).max()
