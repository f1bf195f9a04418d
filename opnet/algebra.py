"""The algebra of shape differences: functoriality (eq. 5), interpolation (eq. 6), analogy (section 7).

Equation numbers are those of the paper as typeset (eq. 1 functional map, 2 shape
difference, 3–4 area and conformal, 5 functoriality, 6 interpolation, 7–8 extrinsic, 9 loss).

Conformal and extrinsic differences are singular (the constant function is in the
kernel of ``Λ_0`` and of ``Φ_0ᵀ E^D Φ_0``) and not symmetric, so a plain matrix
logarithm fails on them. Every ``D = K_0⁺ M`` (``K_0``, ``M`` symmetric PSD) has the kernel
``Z`` of ``K_0`` as a *left* kernel: ``Zᵀ D = 0``. With ``Q`` an orthonormal complement of
``Z``, ``D = Q (B Qᵀ + x Zᵀ)`` where ``B = Qᵀ D Q`` equals ``K_0'^{-1} M'`` on the complement,
so it is similar to the SPD matrix ``K_0'^{-1/2} M' K_0'^{-1/2}`` and has positive real
eigenvalues and a real logarithm. ``x = Qᵀ D Z`` is zero for exact functional maps (the
constant function maps to a constant) and small for computed ones.
:func:`interpolate` interpolates ``B`` multiplicatively and ``x`` linearly.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ._checks import real_array

__all__ = ["interpolate", "analogy", "relative_difference", "log_difference"]


def _as_operator(D, name: str) -> np.ndarray:
    D = real_array(name, D)
    if D.ndim != 2 or D.shape[0] != D.shape[1]:
        raise ValueError(f"{name} must be a square (k, k) shape difference, got shape {D.shape}.")
    return D


def _left_kernel_split(Ds, rtol: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    """``(Q, Z)``: ``Z`` spans the common left kernel (``Zᵀ D = 0`` for all ``Ds``), ``Q`` its complement."""
    stacked = np.concatenate([D.T for D in Ds], axis=0)  # z with Dᵀ z = 0 for every D
    _, s, Vt = np.linalg.svd(stacked)
    rank = int(np.sum(s > rtol * s.max())) if s.size and s.max() > 0 else 0
    return Vt[:rank].T, Vt[rank:].T


def _log_positive(B: np.ndarray) -> np.ndarray:
    """Real logarithm of a matrix similar to an SPD one, via its eigen-decomposition."""
    mu, V = np.linalg.eig(B)
    scale = np.abs(mu).max()
    if np.any(mu.real <= 1e-12 * scale) or np.any(np.abs(mu.imag) > 1e-8 * scale):
        raise ValueError(
            "this operator has non-positive or complex eigenvalues off its kernel, so it has no real logarithm and "
            "cannot be interpolated multiplicatively (is it a shape difference?); use scheme='linear'."
        )
    V = V.real
    return V @ np.diag(np.log(mu.real)) @ np.linalg.inv(V)


def log_difference(D) -> tuple[np.ndarray, np.ndarray]:
    """Real logarithm of a shape difference off its kernel: ``(log B, Q)`` with ``B = Qᵀ D Q``.

    ``Q`` ``(k, r)`` is an orthonormal complement of ``D``'s left kernel (the constant
    function for conformal and extrinsic differences; nothing for area ones). ``log B``
    ``(r, r)`` lives in the Lie algebra where eq. 6 interpolates linearly.
    """
    D = _as_operator(D, "D")
    Q, _ = _left_kernel_split([D])
    if Q.shape[1] == 0:
        raise ValueError("D is zero: it has no logarithm (a k = 1 conformal or extrinsic difference is always 0).")
    return _log_positive(Q.T @ D @ Q), Q


def interpolate(D0, D1, t, scheme: str = "multiplicative") -> np.ndarray:
    """Interpolate two shape differences of the same kind and base.

    ``scheme="multiplicative"`` (eq. 6): ``D(t) = exp((1 − t) log D0 + t log D1)``,
    evaluated off the common kernel (see the module docstring) so that the result is
    real and equals ``D0`` at ``t = 0`` and ``D1`` at ``t = 1`` also for singular
    operators. ``scheme="linear"``: ``(1 − t) D0 + t D1``, for comparison (paper, appendix E).

    ``t`` is a scalar (returns ``(k, k)``) or a 1-d array (returns ``(len(t), k, k)``);
    values outside ``[0, 1]`` extrapolate.
    """
    D0, D1 = _as_operator(D0, "D0"), _as_operator(D1, "D1")
    if D0.shape != D1.shape:
        raise ValueError(f"D0 and D1 must have the same shape, got {D0.shape} and {D1.shape}.")
    ts = np.atleast_1d(real_array("t", t))
    if ts.ndim != 1 or len(ts) == 0:
        raise ValueError(f"t must be a number or a non-empty 1-d array, got shape {np.shape(t)}.")
    if scheme == "linear":
        out = (1 - ts)[:, None, None] * D0 + ts[:, None, None] * D1
    elif scheme == "multiplicative":
        Q, Z = _left_kernel_split([D0, D1])
        if Q.shape[1] == 0:
            out = np.zeros((len(ts), *D0.shape))
        else:
            L0, L1 = (_log_positive(Q.T @ D @ Q) for D in (D0, D1))
            x0, x1 = Q.T @ D0 @ Z, Q.T @ D1 @ Z
            out = np.stack(
                [Q @ (scipy.linalg.expm((1 - s) * L0 + s * L1) @ Q.T + ((1 - s) * x0 + s * x1) @ Z.T) for s in ts]
            )
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
    """Functoriality (eq. 5): ``D_ij = C_0i D_0i⁺ D_0j C_0i⁻¹``, the difference of ``S_j`` seen from ``S_i``.

    ``C0i`` ``(k_i, k_0)`` is the functional map from the base to ``S_i`` (a matrix or
    :class:`opnet.FunctionalMap`); a non-square one is inverted in the least-squares sense.
    For conformal and extrinsic differences the identity holds modulo constants: row 0
    of the result (the constant component, which those inner products do not see) is
    not the one ``S_i`` would compute as a base.
    """
    C = real_array("C0i", getattr(C0i, "matrix", C0i))
    D0i, D0j = _as_operator(D0i, "D0i"), _as_operator(D0j, "D0j")
    if C.ndim != 2 or C.shape[1] != D0i.shape[0]:
        raise ValueError(f"C0i must be (k_i, {D0i.shape[0]}), got {C.shape}.")
    return C @ np.linalg.pinv(D0i, rcond=1e-10) @ D0j @ np.linalg.pinv(C, rcond=1e-10)
