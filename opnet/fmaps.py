"""Functional maps between eigenbases (eq. 1 of the paper).

``C_{0i} = Φ_iᵀ A_i Π_{0i} Φ_0`` is a ``k_i × k_0`` matrix that carries the
coefficients of a function on the base ``S_0`` to those of the corresponding function on
``S_i``. ``Π`` comes from a vertex-to-vertex map (``T: S_i → S_0``), a soft map (a
row-stochastic ``n_i × n_0`` matrix), or the identity for meshes in 1-1 correspondence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ._checks import real_array
from .spectral import Eigenbasis

__all__ = ["FunctionalMap", "fmap_from_p2p", "fmap_from_soft_map", "identity_fmap"]


@dataclass(frozen=True, eq=False)
class FunctionalMap:
    """A functional map ``C`` ``(k_target, k_source)`` from ``source`` (the base) to ``target``."""

    matrix: np.ndarray
    source: Eigenbasis
    target: Eigenbasis

    def __post_init__(self):
        _check_bases(self.source, self.target)
        shape = (self.target.k, self.source.k)
        matrix = real_array("matrix", self.matrix)
        if matrix.shape != shape:
            raise ValueError(
                f"a functional map from this source to this target must be (k_target, k_source) = {shape}, "
                f"got {matrix.shape}."
            )
        object.__setattr__(self, "matrix", matrix)

    def transfer(self, coeffs: np.ndarray) -> np.ndarray:
        """Carry source coefficients ``(k_source, ...)`` to target coefficients ``(k_target, ...)``."""
        return self.matrix @ coeffs


def _check_bases(source, target) -> None:
    for name, b in (("source", source), ("target", target)):
        if not isinstance(b, Eigenbasis):
            raise TypeError(f"{name} must be an opnet.Eigenbasis (from opnet.eigenbasis), got {type(b).__name__}.")


def fmap_from_p2p(source: Eigenbasis, target: Eigenbasis, p2p) -> FunctionalMap:
    """Functional map induced by a vertex map ``T``: ``p2p[p]`` is the source vertex of target vertex ``p``.

    ``p2p`` is an integer array ``(n_target,)`` with values in ``[0, n_source)``.
    """
    _check_bases(source, target)
    p2p = np.asarray(p2p)
    n_t, n_s = target.mesh.n_vertices, source.mesh.n_vertices
    if p2p.shape != (n_t,) or p2p.dtype.kind not in "iu":
        raise ValueError(
            f"p2p must be an integer array of shape ({n_t},) (one source vertex per target vertex), "
            f"got {p2p.dtype} array of shape {p2p.shape}."
        )
    if p2p.min() < 0 or p2p.max() >= n_s:
        raise ValueError(
            f"p2p values must be source vertex indices in [0, {n_s - 1}], got range [{p2p.min()}, {p2p.max()}]."
        )
    c = target.evecs.T @ (target.mass[:, None] * source.evecs[p2p])
    return FunctionalMap(c, source, target)


def fmap_from_soft_map(source: Eigenbasis, target: Eigenbasis, soft_map) -> FunctionalMap:
    """Functional map induced by a soft map ``P`` ``(n_target, n_source)``, each row a probability vector.

    ``P`` may be dense or a scipy sparse matrix; row ``p`` is the distribution over
    source vertices that target vertex ``p`` corresponds to.
    """
    _check_bases(source, target)
    n_t, n_s = target.mesh.n_vertices, source.mesh.n_vertices
    if sp.issparse(soft_map) and soft_map.dtype.kind not in "fiu":
        raise TypeError(f"soft_map must hold real probabilities, got {soft_map.dtype} values.")
    P = soft_map.tocsr() if sp.issparse(soft_map) else real_array("soft_map", soft_map, finite=False)
    if P.shape != (n_t, n_s):
        raise ValueError(f"soft_map must have shape (n_target, n_source) = ({n_t}, {n_s}), got {P.shape}.")
    values = P.data if sp.issparse(P) else P
    if not np.all(np.isfinite(values)) or np.any(values < 0):
        raise ValueError("soft_map entries must be finite and non-negative (probabilities).")
    rows = np.asarray(P.sum(axis=1)).ravel()
    if not np.allclose(rows, 1.0, atol=1e-8):
        raise ValueError(
            f"soft_map rows must sum to 1 (row-stochastic); row sums range over [{rows.min():.3g}, {rows.max():.3g}]. "
            "Normalise with P / P.sum(axis=1, keepdims=True)."
        )
    c = target.evecs.T @ (target.mass[:, None] * (P @ source.evecs))
    return FunctionalMap(c, source, target)


def identity_fmap(source: Eigenbasis, target: Eigenbasis) -> FunctionalMap:
    """Functional map of meshes in 1-1 correspondence (vertex ``p`` ↔ vertex ``p``)."""
    _check_bases(source, target)
    if source.mesh.n_vertices != target.mesh.n_vertices:
        raise ValueError(
            f"identity_fmap needs meshes in 1-1 correspondence, but the source has {source.mesh.n_vertices} vertices "
            f"and the target {target.mesh.n_vertices}; use fmap_from_p2p or fmap_from_soft_map."
        )
    return fmap_from_p2p(source, target, np.arange(target.mesh.n_vertices))
