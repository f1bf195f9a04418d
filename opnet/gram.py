"""Theorem 1: the extrinsic Gram operator ``G = Φᵀ A X Xᵀ A Φ`` and the recovery of ``X`` from it."""

from __future__ import annotations

import numpy as np

from ._checks import is_integer, real_array
from .spectral import Eigenbasis

__all__ = ["gram_matrix", "recover_embedding"]


def _check_basis(basis) -> None:
    if not isinstance(basis, Eigenbasis):
        raise TypeError(f"basis must be an opnet.Eigenbasis (opnet.eigenbasis(mesh, k)), got {type(basis).__name__}.")


def gram_matrix(basis: Eigenbasis, X: np.ndarray) -> np.ndarray:
    """``G = Φᵀ A X Xᵀ A Φ`` ``(k, k)`` for coordinates ``X`` ``(n, 3)`` on ``basis``'s mesh.

    Formed as ``F Fᵀ`` with ``F = Φᵀ A X`` ``(k, 3)``: rank at most 3, invariant to
    rotations of ``X``.
    """
    _check_basis(basis)
    X = real_array("X", X, (basis.evecs.shape[0], "d"), hint="to match the basis")
    F = basis.project(X)
    return F @ F.T


def recover_embedding(G: np.ndarray, basis: Eigenbasis, dim: int = 3) -> np.ndarray:
    """Coordinates ``(n, dim)`` whose Gram operator in ``basis`` is ``G`` (proof of Theorem 1).

    With ``G = U Σ Uᵀ`` (top ``dim`` eigenpairs), ``Φᵀ A X R = U √Σ`` for an orthogonal
    ``R``, so ``Φ U √Σ`` is the projection of ``X`` onto the span of ``Φ``, up to an
    orthogonal transformation (a rotation, possibly with a reflection, which ``G``
    cannot see). With a full basis the recovery is exact up to that transformation.
    """
    _check_basis(basis)
    k = basis.k
    G = real_array("G", G, (k, k), hint="to match the basis")
    if not is_integer(dim) or not 1 <= dim <= k:
        raise ValueError(f"dim must be an integer in [1, k={k}], got {dim!r}.")
    w, U = np.linalg.eigh(0.5 * (G + G.T))
    top = np.argsort(w)[::-1][:dim]
    F = U[:, top] * np.sqrt(np.maximum(w[top], 0.0))
    return basis.evecs @ F
