"""Differentiable shape differences in PyTorch: ``D(X) = K_0⁺ Φ_0ᵀ M(X) Φ_0`` as a function of coordinates.

For shapes on the base's triangulation, the fast path of :func:`opnet.shape_differences` is a smooth
function of the vertex coordinates ``X`` ``(B, n, 3)``: the lumped mass ``A(X)``, the cotan weights
``W(X)`` and the extrinsic ``E^D(X)`` (eq. 7) are built from triangle areas and corner cotangents, and
``Φ_0`` and ``K_0⁺`` are constants of the base. :class:`ShapeDifferences` evaluates them with torch, so
they run on CPU or CUDA, in float32 or float64, and autograd gives ``∂D/∂X``, which
:func:`opnet.reconstruct` uses to move vertices until their operators match.

Each channel is its inner product's :meth:`~opnet.InnerProduct.project_torch`: the built-ins share their one
implementation with numpy (:mod:`opnet.inner_products`), and a user's class that implements it works here and in
:func:`opnet.reconstruct`. Each built-in costs ``O(B n k²)`` like the numpy fast path; the extrinsic one keeps its
low-rank form (``E = u aᵀ + a uᵀ − 2 Y Yᵀ``, see :class:`opnet.ExtrinsicInnerProduct`), so no ``n × n`` matrix exists.
Its gradient, ``∂/∂x_p`` of ``Φᵀ E^D Φ``, follows from ``E_ij = ‖x_i − x_j‖² a_i a_j``:
``2 a_p Σ_j a_j (φ_p − φ_j)(φ_p − φ_j)ᵀ (x_p − x_j)`` plus the terms through the areas ``a(X)``.
"""

from __future__ import annotations

import numpy as np
import torch

from ._checks import real_array
from ._deprecation import renamed_keyword, warn_renamed
from .inner_products import get_inner_products, has_torch_form
from .shape_difference import KINDS, base_pinvs
from .spectral import Eigenbasis

__all__ = ["ShapeDifferences", "shape_differences"]


class ShapeDifferences(torch.nn.Module):
    """Shape differences of coordinates on the base's triangulation, differentiable in the coordinates.

    Parameters
    ----------
    base_basis : opnet.Eigenbasis
        The base shape's eigenbasis (``n`` vertices, ``k`` functions); its faces are the shapes' faces.
    channels : sequence of channels (names, instances, ``"module:Class"``)
        The channels, in this order (default: the paper's three, :data:`opnet.KINDS`); each needs a
        :meth:`~opnet.InnerProduct.project_torch` (the built-ins have one).
    device : where the constants live (kept in float64); :meth:`forward` casts them to the input's dtype and
        moves them to its device when they differ, so one module serves float32 and float64, CPU and CUDA.

    Notes
    -----
    Calling the module on ``X`` ``(B, n, 3)`` gives ``(B, len(channels), k, k)``, equal in float64 to
    :func:`opnet.shape_differences` of the same coordinates (to ~1e-12 relative).
    """

    @renamed_keyword("kinds", "channels", where="ShapeDifferences")
    def __init__(self, base_basis: Eigenbasis, channels=KINDS, *, device=None):
        super().__init__()
        if not isinstance(base_basis, Eigenbasis):
            raise TypeError(
                f"base_basis must be an opnet.Eigenbasis (opnet.eigenbasis(base_mesh, k)), got "
                f"{type(base_basis).__name__}."
            )
        ips = get_inner_products(channels)  # the same checks and names as the numpy path
        missing = [ip.name for ip in ips if not has_torch_form(ip)]
        if missing:
            raise ValueError(
                f"the channels {missing} have no torch form: implement project_torch(vertices, faces, evecs) on "
                "their InnerProduct class (tensors (B, n, 3), (m, 3), (n, k) -> (B, k, k), differentiable) to "
                "optimise coordinates against them; their operators alone come from opnet.shape_differences."
            )
        self.inner_products = ips
        self.channels = tuple(ip.name for ip in ips)
        self.n_vertices, self.k = base_basis.mesh.n_vertices, base_basis.k
        k0_pinv = np.stack(base_pinvs(base_basis, ips))
        self.register_buffer(
            "faces", torch.tensor(np.asarray(base_basis.mesh.faces), dtype=torch.long, device=device), persistent=False
        )
        for name, value in (("phi", base_basis.evecs), ("k0_pinv", k0_pinv)):
            self.register_buffer(
                name, torch.tensor(np.asarray(value), dtype=torch.float64, device=device), persistent=False
            )

    @property
    def kinds(self) -> tuple:
        """Deprecated name of ``channels`` (warns once)."""
        warn_renamed("ShapeDifferences.kinds", "ShapeDifferences.channels")
        return self.channels

    def forward(self, X: torch.Tensor) -> torch.Tensor:
        """``(B, n, 3)`` coordinates → ``(B, len(channels), k, k)`` shape differences ``K_0⁺ Φᵀ M(X) Φ``."""
        K = self.project(X)
        return self.k0_pinv.to(K) @ K

    def project(self, X: torch.Tensor) -> torch.Tensor:
        """``Φᵀ M_c(X) Φ`` ``(B, len(channels), k, k)`` of each channel ``c``, before ``K_0⁺`` (the ``K_i`` of
        eq. 2): each channel's :meth:`~opnet.InnerProduct.project_torch`.
        """
        X = self._check(X)
        phi, faces = self.phi.to(X), self.faces.to(X.device)
        out = []
        for ip in self.inner_products:
            K = ip.project_torch(X, faces, phi)
            if not isinstance(K, torch.Tensor) or tuple(K.shape) != (len(X), self.k, self.k):
                raise ValueError(
                    f"{type(ip).__name__}.project_torch (inner product {ip.name!r}) returned "
                    f"{tuple(K.shape) if isinstance(K, torch.Tensor) else type(K).__name__}; it must return a "
                    f"tensor of shape ({len(X)}, {self.k}, {self.k})."
                )
            out.append(K)
        return torch.stack(out, dim=1)

    def _check(self, X) -> torch.Tensor:
        if not isinstance(X, torch.Tensor):  # arrays and lists: checked, then in the basis' precision
            X = torch.as_tensor(real_array("X", X, ("B", self.n_vertices, 3), finite=False), dtype=self.phi.dtype)
        if X.is_complex() or not (X.is_floating_point() or X.dtype in (torch.int32, torch.int64)):
            raise TypeError(f"X must hold real numbers, got {X.dtype}; pass float32 or float64 coordinates.")
        if X.ndim != 3 or tuple(X.shape[1:]) != (self.n_vertices, 3):
            raise ValueError(
                f"X must have shape (B, {self.n_vertices}, 3) (coordinates on the base's triangulation), "
                f"got {tuple(X.shape)}."
            )
        if len(X) == 0:
            raise ValueError("X is an empty batch (B = 0); pass at least one shape.")
        if not X.is_floating_point():
            X = X.to(self.phi.dtype)
        if not torch.isfinite(X).all():
            raise ValueError("X contains NaN or infinite coordinates.")
        return X

    def extra_repr(self) -> str:
        return f"channels={self.channels}, n_vertices={self.n_vertices}, k={self.k}"


@renamed_keyword("kinds", "channels")
def shape_differences(base_basis: Eigenbasis, X: torch.Tensor, channels=KINDS) -> torch.Tensor:
    """Shorthand for ``ShapeDifferences(base_basis, channels)(X)`` (builds the constants on each call)."""
    X = torch.as_tensor(X)
    return ShapeDifferences(base_basis, channels, device=X.device)(X)
