"""Checks for people writing a new inner product: :func:`~opnet.testing.check_inner_product`."""

from __future__ import annotations

import importlib.util

import numpy as np
from scipy.spatial.transform import Rotation

from .inner_products import checked_gram, get_inner_product, has_torch_form
from .mesh import Mesh
from .spectral import eigenbasis

__all__ = ["check_inner_product"]


def check_inner_product(ip, mesh: Mesh, *, k: int = 20, rtol: float = 1e-8) -> dict:
    """Check that ``ip`` behaves as an inner product on ``mesh`` in a ``k``-function eigenbasis.

    Required (an ``AssertionError`` lists every one that fails, one line each):

    - ``project`` returns a real, finite ``(k, k)`` array, symmetric (``Φᵀ M Φ`` of a symmetric ``M``);
    - it is positive semi-definite (no eigenvalue below ``-rtol`` times the largest magnitude);
    - ``project_batch`` of two shapes equals ``project`` of each (when you override it for speed);
    - ``project_torch`` of the same two shapes (float64 tensors) equals ``project``, and is differentiable (when you
      implement it: :func:`opnet.reconstruct` and :mod:`opnet.torch_ops` use it).

    Reported, not required: whether ``Φᵀ M Φ`` is invariant to a rigid motion of the shape (a rotation and
    a translation). Intrinsic and distance-based inner products are; one that weights by height, say, is not,
    and then the operators (and OperatorNet's input) change when the shape moves.

    Returns ``{"symmetric", "psd", "batch_equals_single", "torch_equals_numpy", "rigid_invariant"}`` → bool (the
    required ones ``True``; ``torch_equals_numpy`` is ``None`` without a ``project_torch``, or without torch
    installed: nothing can call it then).
    """
    ip = get_inner_product(ip)
    if not isinstance(mesh, Mesh):
        raise TypeError(f"mesh must be an opnet.Mesh to test the inner product on, got {type(mesh).__name__}.")
    basis = eigenbasis(mesh, k)
    v, f, phi = mesh.vertices, mesh.faces, basis.evecs
    moved = v @ Rotation.from_euler("xyz", [0.3, -0.7, 1.1]).as_matrix().T + [0.5, -1.0, 2.0]
    stretched = v * [1.2, 1.0, 0.8]  # another shape on the same faces, for the batch
    failures = []
    try:
        K = checked_gram(ip, "project", v, f, phi)
    except ValueError as exc:  # the wrong shape, NaN, or not symmetric: nothing else can be judged
        raise AssertionError(f"{type(ip).__name__} is not an inner product on this mesh:\n- {exc}") from None
    scale = np.abs(K).max()
    w = np.linalg.eigvalsh(K)
    result = {"symmetric": True, "psd": bool(w.min() >= -rtol * max(np.abs(w).max(), scale))}
    if not result["psd"]:
        failures.append(
            f"not positive semi-definite: eigenvalue {w.min():.3g} (largest {w.max():.3g}); ⟨f, f⟩ must be "
            "≥ 0 for every function, so M must be positive semi-definite."
        )
    batch = np.asarray(ip.project_batch(np.stack([v, stretched]), f, phi))
    single = np.stack([K, checked_gram(ip, "project", stretched, f, phi)])
    result["batch_equals_single"] = bool(
        batch.shape == single.shape and np.allclose(batch, single, rtol=1e-6, atol=1e-9 * scale)
    )
    if not result["batch_equals_single"]:
        failures.append(
            f"project_batch differs from project shape by shape (shape {batch.shape} vs {single.shape}"
            + (f", largest difference {np.abs(batch - single).max():.3g}" if batch.shape == single.shape else "")
            + "); fix project_batch or do not override it."
        )
    result["torch_equals_numpy"] = None
    if has_torch_form(ip) and importlib.util.find_spec("torch") is not None:  # a core-only install cannot run it
        message = _torch_mismatch(ip, np.stack([v, stretched]), f, phi, single, scale)
        result["torch_equals_numpy"] = message is None
        if message:
            failures.append(message)
    result["rigid_invariant"] = bool(
        np.allclose(checked_gram(ip, "project", moved, f, phi), K, rtol=1e-6, atol=1e-9 * scale)
    )
    if failures:
        raise AssertionError(
            f"{type(ip).__name__} fails {len(failures)} of the inner-product properties:\n"
            + "\n".join(f"- {m}" for m in failures)
        )
    return result


def _torch_mismatch(ip, vertices, faces, phi, expected, scale) -> str | None:
    """Why ``ip.project_torch`` differs from ``project`` on ``vertices`` ``(2, n, 3)`` (``None`` when it agrees)."""
    from ._extras import require

    torch = require("torch", "opnet.testing.check_inner_product (project_torch)")
    X = torch.tensor(vertices, dtype=torch.float64, requires_grad=True)
    try:
        K = ip.project_torch(X, torch.tensor(faces, dtype=torch.long), torch.tensor(phi, dtype=torch.float64))
    except Exception as exc:  # the user's code: any failure is a finding
        return f"project_torch raised {type(exc).__name__}: {exc}"
    if not isinstance(K, torch.Tensor) or tuple(K.shape) != expected.shape:
        got = tuple(K.shape) if isinstance(K, torch.Tensor) else type(K).__name__
        return f"project_torch returned {got}, not a tensor of shape {expected.shape}."
    if not K.requires_grad:
        return "project_torch's result does not depend on the vertices through autograd (no gradient flows)."
    K = K.detach().numpy()
    if not np.allclose(K, expected, rtol=1e-6, atol=1e-9 * scale):
        return f"project_torch differs from project (largest difference {np.abs(K - expected).max():.3g})."
    return None
