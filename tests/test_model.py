"""OperatorNet and its rigid-motion-invariant loss (eq. 9)."""

import pytest

pytest.importorskip("torch")  # the net extra: skipped by a core-only install

import numpy as np
import torch
from scipy.spatial.transform import Rotation

import opnet
from opnet.data import toy


@pytest.mark.parametrize("depth", [1, 2, 3, 4])
@pytest.mark.parametrize("channels", [("area",), ("extrinsic",), ("area", "conformal", "extrinsic")])
def test_shapes(depth, channels):
    net = opnet.OperatorNet(n_vertices=50, k=60, channels=channels, depth=depth, hidden=32)
    out = net(torch.randn(2, len(channels), 60, 60))
    assert out.shape == (2, 50, 3) and out.dtype == torch.float32
    convs = [m for m in net.encoder if isinstance(m, torch.nn.Conv2d)]
    assert [c.out_channels for c in convs] == [8, 16, 32, 64][:depth]
    assert all(c.kernel_size == (3, 3) and c.stride == (2, 2) for c in convs)
    assert [m.out_features for m in net.decoder if isinstance(m, torch.nn.Linear)] == [32, 32, 150]


def test_bad_configurations_and_inputs():
    with pytest.raises(ValueError, match="depth"):
        opnet.OperatorNet(50, depth=5)
    with pytest.raises(ValueError, match="channels"):
        opnet.OperatorNet(50, channels=("area", "area"))
    assert opnet.OperatorNet(50, k=8, channels=("area", "my volume"), hidden=8).channels == ("area", "my volume")
    with pytest.raises(ValueError, match=r"\(B, 3, 60, 60\)"):
        opnet.OperatorNet(50, hidden=8)(torch.randn(2, 2, 60, 60))
    with pytest.raises(ValueError, match=r"\(B, n, 3\)"):
        opnet.rigid_alignment_loss(torch.randn(2, 5, 3), torch.randn(2, 6, 3))


def _random_pair(n=40, seed=0):
    g = torch.Generator().manual_seed(seed)
    return torch.randn(3, n, 3, generator=g, dtype=torch.float64), torch.randn(
        3, n, 3, generator=g, dtype=torch.float64
    )


def test_loss_is_eq9_and_invariant_to_rigid_motions_of_the_prediction():
    pred, target = _random_pair()
    loss = opnet.rigid_alignment_loss(pred, target)
    np.testing.assert_allclose(loss.item(), opnet.d_R(target.numpy(), pred.numpy()).mean(), rtol=1e-12)
    R = torch.from_numpy(Rotation.random(3, random_state=0).as_matrix())
    moved = pred @ R.transpose(1, 2) + torch.tensor([1.0, -2.0, 3.0], dtype=torch.float64)
    np.testing.assert_allclose(opnet.rigid_alignment_loss(moved, target).item(), loss.item(), rtol=1e-10)
    mirrored = pred * torch.tensor([-1.0, 1.0, 1.0], dtype=torch.float64)
    assert abs(opnet.rigid_alignment_loss(mirrored, target).item() - loss.item()) > 1e-3  # no reflections
    assert opnet.rigid_alignment_loss(moved, pred).item() < 1e-20


def test_gradient_matches_finite_differences_of_the_minimum():
    """Danskin: the gradient with the optimal motion held fixed is the gradient of the minimised loss."""
    pred, target = _random_pair(n=8, seed=1)
    pred.requires_grad_(True)
    assert torch.autograd.gradcheck(lambda p: opnet.rigid_alignment_loss(p, target), (pred,), eps=1e-6, atol=1e-6)


def test_gradient_is_finite_on_degenerate_shapes():
    target = torch.zeros(1, 10, 3, dtype=torch.float64)
    target[0, :, 0] = torch.linspace(0, 1, 10)  # collinear points: two singular values vanish
    pred = target.clone().requires_grad_(True)
    opnet.rigid_alignment_loss(pred, target).backward()
    assert torch.isfinite(pred.grad).all()
    flat = torch.zeros(1, 10, 3, dtype=torch.float32, requires_grad=True)  # all points equal
    opnet.rigid_alignment_loss(flat, target.float()).backward()
    assert torch.isfinite(flat.grad).all()


def test_a_short_training_run_lowers_the_loss():
    torch.manual_seed(0)
    base = toy.capsule("quick")
    basis = opnet.eigenbasis(base, 20)
    angles = np.linspace(-1.2, 1.2, 24)
    V = np.stack([toy.bend(toy.bulge(base.vertices, 0.2 * np.sin(3 * a)), a) for a in angles])
    ops = torch.from_numpy(opnet.shape_differences(basis, V, progress=False).astype(np.float32))
    X = torch.from_numpy(V.astype(np.float32))
    net = opnet.OperatorNet(base.n_vertices, k=20, hidden=128)
    optim = torch.optim.Adam(net.parameters(), lr=1e-3)
    losses = []
    for _ in range(150):
        optim.zero_grad()
        loss = opnet.rigid_alignment_loss(net(ops), X)
        loss.backward()
        optim.step()
        losses.append(loss.item())
    assert losses[-1] < 0.1 * losses[0]
