"""Rigid alignment (Kabsch, no reflections) and the paper's reconstruction metrics (section 6, eq. 9)."""

from __future__ import annotations

import numpy as np

from ._checks import real_array
from .mesh import as_faces, edge_face_counts, unique_edges

__all__ = ["kabsch", "rigid_align", "d_R", "d_V", "d_E", "mesh_volume"]


def _pair(X, Y, names=("X", "Y")) -> tuple[np.ndarray, np.ndarray]:
    X, Y = real_array(names[0], X), real_array(names[1], Y)
    if X.shape != Y.shape or X.ndim < 2 or X.shape[-1] != 3 or X.shape[-2] == 0:
        raise ValueError(
            f"{names[0]} and {names[1]} must have the same shape (..., n, 3) with n >= 1 points, got "
            f"{X.shape} and {Y.shape}."
        )
    return X, Y


def kabsch(X, Y) -> tuple[np.ndarray, np.ndarray]:
    """Rotation ``R`` ``(..., 3, 3)`` and translation ``t`` ``(..., 3)`` minimising ``Σ‖R x_p + t − y_p‖²``.

    ``X``, ``Y``: ``(..., n, 3)`` in correspondence. ``det R = +1`` (no reflections).
    """
    X, Y = _pair(X, Y)
    mx, my = X.mean(-2), Y.mean(-2)
    H = np.swapaxes(X - mx[..., None, :], -1, -2) @ (Y - my[..., None, :])  # (..., 3, 3)
    U, _, Vt = np.linalg.svd(H)
    S = np.broadcast_to(np.eye(3), H.shape).copy()
    S[..., 2, 2] = np.where(np.linalg.det(np.swapaxes(Vt, -1, -2) @ np.swapaxes(U, -1, -2)) < 0, -1.0, 1.0)
    R = np.swapaxes(Vt, -1, -2) @ S @ np.swapaxes(U, -1, -2)
    t = my - np.einsum("...ij,...j->...i", R, mx)
    return R, t


def rigid_align(X, Y) -> np.ndarray:
    """``X`` moved by the optimal rigid motion onto ``Y`` (both ``(..., n, 3)``)."""
    R, t = kabsch(X, Y)
    return np.asarray(X) @ np.swapaxes(R, -1, -2) + t[..., None, :]


def d_R(X_gt, X_recon) -> np.ndarray:
    """Eq. 9 (the loss ``L``): mean squared vertex error after rigidly aligning ``X_recon`` to ``X_gt`` (length²)."""
    X_gt, X_recon = _pair(X_gt, X_recon, ("X_gt", "X_recon"))
    return np.mean(np.sum((rigid_align(X_recon, X_gt) - X_gt) ** 2, axis=-1), axis=-1)


def mesh_volume(vertices, faces) -> np.ndarray:
    """Signed enclosed volume ``(...)`` of closed meshes ``(..., n, 3)`` (divergence theorem; length³).

    Positive for outward-oriented faces. Only meaningful for a closed surface.
    """
    v = real_array("vertices", vertices, (..., "n", 3))
    v = v[..., as_faces(faces, v.shape[-2]), :]
    return np.einsum("...i,...i->...", v[..., 0, :], np.cross(v[..., 1, :], v[..., 2, :])).sum(-1) / 6.0


def d_V(X_gt, X_recon, faces) -> np.ndarray:
    """Relative volume error ``| |V(S_gt)| − |V(S_recon)| | / |V(S_gt)|`` of closed meshes sharing ``faces``.

    Volumes are taken unsigned, so a mirror image has the same volume. Raises
    ``ValueError`` for an open mesh, whose enclosed volume is undefined.
    """
    X_gt, X_recon = _pair(X_gt, X_recon, ("X_gt", "X_recon"))
    f = as_faces(faces, X_gt.shape[-2])
    if np.any(edge_face_counts(f)[1] != 2):
        raise ValueError("d_V needs a closed mesh (every edge in exactly two faces); this one has boundary edges.")
    v_gt = np.abs(mesh_volume(X_gt, f))
    return np.abs(v_gt - np.abs(mesh_volume(X_recon, f))) / v_gt


def d_E(X_gt, X_recon, faces) -> np.ndarray:
    """Mean relative edge-length error ``mean |l_gt − l_recon| / l_gt`` over the unique edges of ``faces``."""
    X_gt, X_recon = _pair(X_gt, X_recon, ("X_gt", "X_recon"))
    e = unique_edges(as_faces(faces, X_gt.shape[-2]))

    def lengths(X):
        return np.linalg.norm(X[..., e[:, 0], :] - X[..., e[:, 1], :], axis=-1)

    l_gt = lengths(X_gt)
    if np.any(l_gt == 0):
        raise ValueError("the ground truth has zero-length edges, so relative edge errors are undefined.")
    return np.mean(np.abs(l_gt - lengths(X_recon)) / l_gt, axis=-1)
