"""The algebra of shape differences: functoriality (eq. 6), interpolation (eq. 7), analogy.

Conformal and extrinsic differences are singular (the constant function is in the
kernel of ``Λ_0`` and of ``Φ_0ᵀ E^D Φ_0``) and not symmetric, so a plain matrix
logarithm fails on them. Each ``D = K_0⁺ M`` with ``K_0``, ``M`` symmetric PSD with the
same kernel ``Z`` satisfies ``D Z = 0`` and ``Zᵀ D = 0``; on the complement ``Q`` of
``Z``, ``B = Qᵀ D Q`` is similar to the SPD matrix ``K_0^{-1/2} M K_0^{-1/2}``, so it has
positive real eigenvalues and a real logarithm. :func:`interpolate` works on ``B``
and maps back with ``D(t) = Q exp(...) Qᵀ``.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["interpolate", "analogy", "relative_difference", "log_difference"]


def _as_operator(D, name: str) -> np.ndarray:
    D = np.asarray(D, dtype=np.float64)
    if D.ndim != 2 or D.shape[0] != D.shape[1]:
        raise ValueError(f"{name} must be a square (k, k) shape difference, got shape {D.shape}.")
    if not np.isfinite(D).all():
        raise ValueError(f"{name} contains NaN or infinite values.")
    return D


def _common_range(Ds, rtol: float = 1e-8) -> np.ndarray:
    """Orthonormal ``Q`` ``(k, r)`` spanning the complement of the common left/right kernel of ``Ds``."""
    stacked = np.concatenate([m for D in Ds for m in (D, D.T)], axis=0)
    _, s, Vt = np.linalg.svd(stacked)
    return Vt[s > rtol * s.max()].T


def log_difference(D, Q: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Real logarithm of a shape difference on its range: ``(log B, Q)`` with ``D = Q B Qᵀ``.

    ``Q`` ``(k, r)`` defaults to the complement of ``D``'s kernel. Raises ``ValueError``
    if ``D`` has a non-positive or complex eigenvalue there (it then is no shape
    difference, and only linear interpolation applies).
    """
    D = _as_operator(D, "D")
    Q = _common_range([D]) if Q is None else Q
    B = Q.T @ D @ Q
    if not np.allclose(Q @ B @ Q.T, D, atol=1e-8 * np.abs(D).max()):
        raise ValueError("the operators do not share their kernel, so they are not differences from one base shape.")
    ev = np.linalg.eigvals(B)
    if np.any(ev.real <= 0) or np.any(np.abs(ev.imag) > 1e-6 * np.abs(ev).max()):
        raise ValueError(
            "this operator has non-positive or complex eigenvalues on its range, so it has no real logarithm and "
            "cannot be interpolated multiplicatively; use scheme='linear'."
        )
    L = scipy.linalg.logm(B)
    return np.real(L), Q


def interpolate(D0, D1, t, scheme: str = "multiplicative") -> np.ndarray:
    """Interpolate two shape differences of the same kind and base.

    ``scheme="multiplicative"`` (eq. 7): ``D(t) = exp((1 − t) log D0 + t log D1)``,
    evaluated on the common range of ``D0`` and ``D1`` (see the module docstring), so the
    result is real and equals ``D0`` at ``t = 0`` and ``D1`` at ``t = 1``.
    ``scheme="linear"``: ``(1 − t) D0 + t D1``, for comparison (paper, appendix E).

    ``t`` is a scalar (returns ``(k, k)``) or a 1-d array (returns ``(len(t), k, k)``);
    values outside ``[0, 1]`` extrapolate.
    """
    D0, D1 = _as_operator(D0, "D0"), _as_operator(D1, "D1")
    if D0.shape != D1.shape:
        raise ValueError(f"D0 and D1 must have the same shape, got {D0.shape} and {D1.shape}.")
    ts = np.atleast_1d(np.asarray(t, dtype=np.float64))
    if ts.ndim != 1 or not np.isfinite(ts).all():
        raise ValueError("t must be a finite scalar or 1-d array.")
    if scheme == "linear":
        out = (1 - ts)[:, None, None] * D0 + ts[:, None, None] * D1
    elif scheme == "multiplicative":
        Q = _common_range([D0, D1])
        L0, _ = log_difference(D0, Q)
        L1, _ = log_difference(D1, Q)
        out = np.stack([Q @ scipy.linalg.expm((1 - s) * L0 + s * L1) @ Q.T for s in ts])
    else:
        raise ValueError(f"scheme must be 'multiplicative' or 'linear', got {scheme!r}.")
    return out[0] if np.ndim(t) == 0 else out


def analogy(DA, DB, DC) -> np.ndarray:
    """Shape analogy ``D_X = D_C D_A⁺ D_B`` (section 7 of the paper).

    ``S_X`` is to ``S_C`` what ``S_B`` is to ``S_A`` ("A : B :: C : X"); all four
    operators are differences from the same base. The order matters: the operators do
    not commute in general.
    """
    DA, DB, DC = (_as_operator(D, n) for D, n in ((DA, "DA"), (DB, "DB"), (DC, "DC")))
    if not DA.shape == DB.shape == DC.shape:
        raise ValueError(f"DA, DB, DC must have the same shape, got {DA.shape}, {DB.shape}, {DC.shape}.")
    return DC @ np.linalg.pinv(DA, rcond=1e-10) @ DB


def relative_difference(D0i, D0j, C0i) -> np.ndarray:
    """Functoriality (eq. 6): ``D_ij = C_0i D_0i⁺ D_0j C_0i⁻¹``, the difference of ``S_j`` seen from ``S_i``.

    ``C0i`` ``(k_i, k_0)`` is the functional map from the base to ``S_i`` (a matrix or
    :class:`opnet.FunctionalMap`); a non-square one is inverted in the least-squares sense.
    """
    C = np.asarray(getattr(C0i, "matrix", C0i), dtype=np.float64)
    D0i, D0j = _as_operator(D0i, "D0i"), _as_operator(D0j, "D0j")
    if C.ndim != 2 or C.shape[1] != D0i.shape[0]:
        raise ValueError(f"C0i must be (k_i, {D0i.shape[0]}), got {C.shape}.")
    return C @ np.linalg.pinv(D0i, rcond=1e-10) @ D0j @ np.linalg.pinv(C, rcond=1e-10)
