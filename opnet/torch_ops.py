"""Differentiable shape differences in PyTorch: ``D(X) = K_0⁺ Φ_0ᵀ M(X) Φ_0`` as a function of coordinates.

For shapes on the base's triangulation, the fast path of :func:`opnet.shape_differences` is a smooth
function of the vertex coordinates ``X`` ``(B, n, 3)``: the lumped mass ``A(X)``, the cotan weights
``W(X)`` and the extrinsic ``E^D(X)`` (eq. 7) are built from triangle areas and corner cotangents, and
``Φ_0`` and ``K_0⁺`` are constants of the base. :class:`ShapeDifferences` evaluates them with torch, so
they run on CPU or CUDA, in float32 or float64, and autograd gives ``∂D/∂X``, which
:func:`opnet.reconstruct` uses to move vertices until their operators match.

Each kind costs ``O(B n k²)`` like the numpy fast path; the extrinsic one keeps its low-rank form
(``E = u aᵀ + a uᵀ − 2 Y Yᵀ``, see :class:`opnet.ExtrinsicInnerProduct`), so no ``n × n`` matrix exists.
Its gradient, ``∂/∂x_p`` of ``Φᵀ E^D Φ``, follows from ``E_ij = ‖x_i − x_j‖² a_i a_j``:
``2 a_p Σ_j a_j (φ_p − φ_j)(φ_p − φ_j)ᵀ (x_p − x_j)`` plus the terms through the areas ``a(X)``.
"""

from __future__ import annotations

import numpy as np
import torch

from ._checks import real_array
from .inner_products import INNER_PRODUCTS, get_inner_products
from .mesh import unique_edges
from .shape_difference import KINDS, base_pinvs
from .spectral import Eigenbasis, _corner_to_edge

__all__ = ["ShapeDifferences", "shape_differences"]


def _vertex_areas(X: torch.Tensor, faces: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Barycentric lumped mass ``(B, n)`` and the corners' edge vectors, for ``X`` ``(B, n, 3)``."""
    v = X[:, faces]  # (B, m, 3, 3)
    cross = torch.linalg.cross(v[:, :, 1] - v[:, :, 0], v[:, :, 2] - v[:, :, 0])
    double_area = torch.linalg.vector_norm(cross, dim=-1)  # (B, m)
    a = X.new_zeros(X.shape[:2]).index_add_(1, faces.reshape(-1), (double_area / 6.0).repeat_interleave(3, dim=1))
    return a, double_area


def _weighted_gram(phi: torch.Tensor, w: torch.Tensor) -> torch.Tensor:
    """``Φᵀ diag(w_b) Φ`` ``(B, k, k)`` for ``Φ`` ``(p, k)`` and weights ``w`` ``(B, p)``."""
    return (phi.T.unsqueeze(0) * w.unsqueeze(1)) @ phi


class ShapeDifferences(torch.nn.Module):
    """Shape differences of coordinates on the base's triangulation, differentiable in the coordinates.

    Parameters
    ----------
    base_basis : opnet.Eigenbasis
        The base shape's eigenbasis (``n`` vertices, ``k`` functions); its faces are the shapes' faces.
    kinds : sequence of ``"area"``, ``"conformal"``, ``"extrinsic"``
        The channels, in this order (default: all three, the order of :data:`opnet.KINDS`).
    device : where the constants live (kept in float64); :meth:`forward` casts them to the input's dtype and
        moves them to its device when they differ, so one module serves float32 and float64, CPU and CUDA.

    Notes
    -----
    Calling the module on ``X`` ``(B, n, 3)`` gives ``(B, len(kinds), k, k)``, equal in float64 to
    :func:`opnet.shape_differences` of the same coordinates (to ~1e-12 relative).
    """

    def __init__(self, base_basis: Eigenbasis, kinds=KINDS, *, device=None):
        super().__init__()
        if not isinstance(base_basis, Eigenbasis):
            raise TypeError(
                f"base_basis must be an opnet.Eigenbasis (opnet.eigenbasis(base_mesh, k)), got "
                f"{type(base_basis).__name__}."
            )
        ips = get_inner_products(kinds)  # the same checks and names as the numpy path
        custom = [type(ip).__name__ for ip in ips if type(ip) is not type(INNER_PRODUCTS.get(ip.name))]
        if custom:
            raise ValueError(
                f"kinds must be built-in kinds of {KINDS}; {custom} have no torch form: compute them with "
                "opnet.shape_differences."
            )
        kinds = tuple(ip.name for ip in ips)
        self.kinds, self.n_vertices, self.k = kinds, base_basis.mesh.n_vertices, base_basis.k
        mesh = base_basis.mesh
        faces, edges = mesh.faces, unique_edges(mesh.faces)
        corner_edge = _corner_to_edge(faces, edges).indices  # the edge opposite each corner, (3m,)
        k0_pinv = np.stack(base_pinvs(base_basis, kinds))
        phi = base_basis.evecs
        for name, value in (("faces", faces), ("corner_edge", corner_edge)):
            self.register_buffer(
                name, torch.tensor(np.asarray(value), dtype=torch.long, device=device), persistent=False
            )
        for name, value in (("phi", phi), ("edge_phi", phi[edges[:, 0]] - phi[edges[:, 1]]), ("k0_pinv", k0_pinv)):
            self.register_buffer(
                name, torch.tensor(np.asarray(value), dtype=torch.float64, device=device), persistent=False
            )
        self.n_edges = len(edges)

    def forward(self, X: torch.Tensor) -> torch.Tensor:
        """``(B, n, 3)`` coordinates → ``(B, len(kinds), k, k)`` shape differences ``K_0⁺ Φᵀ M(X) Φ``."""
        K = self.project(X)
        return self.k0_pinv.to(K) @ K

    def project(self, X: torch.Tensor) -> torch.Tensor:
        """``Φᵀ M_c(X) Φ`` ``(B, len(kinds), k, k)`` of each kind ``c``, before ``K_0⁺`` (the ``K_i`` of eq. 2)."""
        X = self._check(X)
        phi = self.phi.to(X)
        faces = self.faces.to(X.device)
        a, double_area = _vertex_areas(X, faces)
        out = []
        for kind in self.kinds:
            if kind == "area":
                out.append(_weighted_gram(phi, a))
            elif kind == "conformal":
                out.append(_weighted_gram(self.edge_phi.to(X), self._cotan_weights(X, faces, double_area)))
            else:
                out.append(self._extrinsic(X, a, phi))
        return torch.stack(out, dim=1)

    def _cotan_weights(self, X, faces, double_area) -> torch.Tensor:
        """``(cot α + cot β) / 2`` ``(B, e)`` per edge, in the order of :func:`opnet.mesh.unique_edges`."""
        v = X[:, faces]  # (B, m, 3, 3)
        cots = []
        for c in range(3):
            e1, e2 = v[:, :, (c + 1) % 3] - v[:, :, c], v[:, :, (c + 2) % 3] - v[:, :, c]
            cots.append((e1 * e2).sum(-1) / double_area)
        cot = torch.stack(cots, dim=-1).reshape(len(X), -1)  # corner order of _corner_to_edge
        return X.new_zeros(len(X), self.n_edges).index_add_(1, self.corner_edge.to(X.device), 0.5 * cot)

    @staticmethod
    def _extrinsic(X, a, phi) -> torch.Tensor:
        """``Φᵀ E^D Φ`` by the low-rank form of :class:`opnet.ExtrinsicInnerProduct` (same algebra, in torch)."""
        v = X - (a.unsqueeze(-1) * X).sum(1, keepdim=True) / a.sum(1)[:, None, None]
        u = a * (v * v).sum(-1)  # (B, n)
        y = a.unsqueeze(-1) * v  # (B, n, 3)
        rowsum = u * a.sum(1, keepdim=True) + a * u.sum(1, keepdim=True) - 2 * (y @ y.sum(1).unsqueeze(-1)).squeeze(-1)
        pa, pu, py = phi.T @ a.unsqueeze(-1), phi.T @ u.unsqueeze(-1), phi.T @ y  # (B, k, 1|1|3)
        low_rank = pu @ pa.transpose(1, 2) + pa @ pu.transpose(1, 2) - 2 * py @ py.transpose(1, 2)
        return _weighted_gram(phi, rowsum) - low_rank

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
        return f"kinds={self.kinds}, n_vertices={self.n_vertices}, k={self.k}"


def shape_differences(base_basis: Eigenbasis, X: torch.Tensor, kinds=KINDS) -> torch.Tensor:
    """Shorthand for ``ShapeDifferences(base_basis, kinds)(X)`` (builds the constants on each call)."""
    X = torch.as_tensor(X)
    return ShapeDifferences(base_basis, kinds, device=X.device)(X)
