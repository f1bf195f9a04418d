"""Differentiable shape differences (opnet.torch_ops) against the numpy fast path and finite differences."""

import pytest

pytest.importorskip("torch")  # the net extra: skipped by a core-only install

import numpy as np
import torch
import trimesh
from scipy.spatial.transform import Rotation

import opnet
from opnet.torch_ops import ShapeDifferences, shape_differences

KINDS = opnet.KINDS


@pytest.fixture(scope="module")
def deformed(base, targets):
    return np.stack([t.vertices for t in targets])


@pytest.mark.parametrize("channels", [KINDS, ("extrinsic", "area"), ("conformal",)])
def test_float64_equals_numpy_fast_path(base_basis, deformed, channels):
    ref = opnet.shape_differences(base_basis, deformed, channels)
    out = ShapeDifferences(base_basis, channels)(torch.tensor(deformed)).numpy()
    assert out.shape == ref.shape
    for c in range(len(channels)):  # per channel: their scales differ
        assert np.abs(out[:, c] - ref[:, c]).max() <= 1e-10 * np.abs(ref[:, c]).max(), channels[c]


def test_float32_and_identity_at_base(base_basis, deformed):
    module = ShapeDifferences(base_basis)
    ref = opnet.shape_differences(base_basis, deformed)
    out32 = module(torch.tensor(deformed, dtype=torch.float32))
    assert out32.dtype == torch.float32
    assert np.abs(out32.numpy() - ref).max() <= 1e-4 * np.abs(ref).max()
    at_base = module(torch.tensor(base_basis.mesh.vertices[None]))[0]
    k = base_basis.k
    assert torch.allclose(at_base[0], torch.eye(k, dtype=torch.float64), atol=1e-10)  # area: D = I
    assert torch.allclose(at_base[2], torch.eye(k, dtype=torch.float64), atol=1e-8) or torch.allclose(
        at_base[2][1:, 1:], torch.eye(k - 1, dtype=torch.float64), atol=1e-8
    )  # constant in the kernel


def test_invariant_to_rigid_motions(base_basis, deformed):
    R = Rotation.from_euler("xyz", [0.3, -1.1, 2.0]).as_matrix()
    moved = deformed @ R.T + np.array([0.5, -2.0, 3.0])
    f = ShapeDifferences(base_basis)
    assert torch.allclose(f(torch.tensor(moved)), f(torch.tensor(deformed)), atol=1e-9)


@pytest.mark.parametrize("kind", KINDS)
def test_gradcheck(kind):
    sphere = trimesh.creation.icosphere(1)  # 42 vertices
    mesh = opnet.Mesh(sphere.vertices, sphere.faces)
    module = ShapeDifferences(opnet.eigenbasis(mesh, 8), (kind,))
    rng = np.random.default_rng(0)
    X = torch.tensor((mesh.vertices * (1 + 0.1 * rng.standard_normal((42, 1))))[None], requires_grad=True)
    assert torch.autograd.gradcheck(module, (X,), eps=1e-6, atol=1e-7, rtol=1e-5)


def test_gradient_is_not_zero_and_points_back(base_basis, deformed):
    """A step against the gradient of the mismatch lowers it (the gradient is the gradient of this objective)."""
    module = ShapeDifferences(base_basis)
    target = module(torch.tensor(deformed[:1]))
    X = torch.tensor(base_basis.mesh.vertices[None], requires_grad=True)
    loss = ((module(X) - target) ** 2).sum()
    (g,) = torch.autograd.grad(loss, X)
    assert g.abs().max() > 0
    with torch.no_grad():
        assert ((module(X - 1e-4 * g / g.abs().max()) - target) ** 2).sum() < loss


def test_functional_shorthand_and_bad_input(base_basis, deformed):
    assert torch.allclose(
        shape_differences(base_basis, torch.tensor(deformed)), ShapeDifferences(base_basis)(torch.tensor(deformed))
    )
    module = ShapeDifferences(base_basis)
    n = base_basis.mesh.n_vertices
    with pytest.raises(ValueError, match=rf"\(B, {n}, 3\)"):
        module(torch.zeros(2, n + 1, 3, dtype=torch.float64))
    with pytest.raises(ValueError, match="NaN"):
        module(torch.full((1, n, 3), float("nan"), dtype=torch.float64))
    with pytest.raises(TypeError, match="real"):
        module(torch.zeros(1, n, 3, dtype=torch.complex128))
    with pytest.raises(TypeError, match="Eigenbasis"):
        ShapeDifferences(base_basis.mesh)
    with pytest.raises(TypeError, match="not a single one"):
        ShapeDifferences(base_basis, "area")

    class Doubled(opnet.InnerProduct):  # a custom inner product without a torch form
        name = "doubled area"

        def project(self, vertices, faces, evecs):
            return 2 * opnet.AreaInnerProduct().project(vertices, faces, evecs)

    with pytest.raises(ValueError, match=r"\['doubled area'\] have no torch form: implement project_torch"):
        ShapeDifferences(base_basis, ("area", Doubled()))

    class Doubled3(Doubled):  # ... and with one: it works like a built-in
        def project_torch(self, vertices, faces, evecs):
            return 2 * opnet.AreaInnerProduct().project_torch(vertices, faces, evecs)

    twice = ShapeDifferences(base_basis, (Doubled3(),))(deformed)
    assert torch.allclose(twice, ShapeDifferences(base_basis, ("area",))(deformed), rtol=1e-12)  # K0 doubles too
    assert torch.allclose(
        ShapeDifferences(base_basis, (Doubled3(),)).project(deformed), 2 * module.project(deformed)[:, :1]
    )
    assert ShapeDifferences(base_basis, (opnet.AreaInnerProduct(), "conformal")).channels == ("area", "conformal")
    # numpy input is accepted (converted losslessly)
    assert torch.allclose(module(deformed), module(torch.tensor(deformed)))


@pytest.mark.parametrize("kind", KINDS)
def test_gradient_sums_to_zero_over_the_vertices(base_basis, deformed, kind):
    """The operators are invariant to translations, so the gradient of any function of them sums to zero."""
    module = ShapeDifferences(base_basis, (kind,))
    X = torch.tensor(deformed[:1], requires_grad=True)
    weights = torch.randn(base_basis.k, base_basis.k, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    (g,) = torch.autograd.grad((module(X)[0, 0] * weights).sum(), X)
    assert g.abs().max() > 0
    assert torch.allclose(g.sum(1), torch.zeros(1, 3, dtype=torch.float64), atol=1e-9 * g.abs().max().item())
