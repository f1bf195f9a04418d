"""Laplace–Beltrami eigenbasis ``W Φ = A Φ Λ`` and batched cotan/area weights.

Single meshes take ``W`` (cotan stiffness) and ``A`` (barycentric lumped mass) from
potpourri3d (see :attr:`opnet.Mesh.stiffness`). Collections that share one
connectivity use :func:`cotan_edge_weights` and :func:`vertex_areas`, which evaluate
the same quantities for a whole batch of coordinates at once with numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg

from . import _memo
from ._backend import areas as tensor_areas
from ._backend import edge_weights as tensor_edge_weights
from ._backend import is_tensor
from ._backend import normals as tensor_normals
from ._checks import real_array
from .mesh import Mesh, as_faces, corner_edges, double_areas, face_edges, face_normals, unique_edges

__all__ = ["Eigenbasis", "eigenbasis", "cotan_edge_weights", "vertex_areas", "vertex_normals"]

# Above this fraction of n the dense solver is cheaper and more reliable than ARPACK.
_DENSE_FRACTION = 0.3
# Largest mesh for which a failed sparse solve falls back to the dense one (memory ~ 8 n² bytes).
_DENSE_LIMIT = 8000


@dataclass(frozen=True, eq=False)
class Eigenbasis:
    """The first ``k`` Laplace–Beltrami eigenpairs of a mesh.

    Attributes
    ----------
    mesh : Mesh
        The mesh the basis lives on.
    evals : (k,) float64
        Ascending eigenvalues ``Λ`` (1 / length²); ``evals[0] == 0`` exactly.
    evecs : (n, k) float64
        Eigenvectors ``Φ``, orthonormal for the mass: ``Φᵀ A Φ = I`` (1 / length).
    mass : (n,) float64
        The lumped mass ``A`` (length²), i.e. ``mesh.mass``.
    """

    mesh: Mesh
    evals: np.ndarray
    evecs: np.ndarray
    mass: np.ndarray

    @property
    def k(self) -> int:
        return len(self.evals)

    def project(self, f: np.ndarray) -> np.ndarray:
        """Coefficients ``Φᵀ A f`` ``(k,)`` or ``(k, d)`` of vertex functions ``f`` ``(n,)`` or ``(n, d)``."""
        f = real_array("f", f)
        if f.ndim not in (1, 2) or len(f) != len(self.mass):
            raise ValueError(f"f must be vertex functions ({len(self.mass)},) or ({len(self.mass)}, d), got {f.shape}.")
        return self.evecs.T @ (self.mass.reshape(-1, *([1] * (f.ndim - 1))) * f)

    def truncate(self, k: int) -> "Eigenbasis":
        """The first ``k`` eigenpairs of this basis."""
        if not isinstance(k, (int, np.integer)) or not 1 <= k <= self.k:
            raise ValueError(f"k must be in [1, {self.k}] to truncate this basis, got {k}.")
        return Eigenbasis(self.mesh, self.evals[:k], self.evecs[:, :k], self.mass)


def _fix_signs(evecs: np.ndarray) -> np.ndarray:
    """Flip each column so that its entry of largest magnitude is positive.

    Near-ties (mirror-symmetric meshes have ±max pairs) go to the lowest vertex index,
    so rounding noise cannot flip a sign.
    """
    mag = np.abs(evecs)
    idx = np.argmax(mag >= mag.max(axis=0) * (1 - 1e-6), axis=0)
    signs = np.sign(evecs[idx, np.arange(evecs.shape[1])])
    signs[signs == 0] = 1
    return evecs * signs


def eigenbasis(mesh: Mesh, k: int) -> Eigenbasis:
    """The ``k`` smallest eigenpairs of ``W φ = λ A φ`` on ``mesh``.

    Eigenvalues are ascending with the first exactly 0 and its eigenvector exactly
    constant; eigenvectors are ``A``-orthonormal with a deterministic sign (largest
    entry positive, ties to the lowest vertex index). The problem is solved at unit area and rescaled, so it behaves the
    same for any scale of the mesh. ``k = n`` (a full basis) uses a dense solver.
    """
    if not isinstance(mesh, Mesh):
        raise TypeError(
            f"eigenbasis expects an opnet.Mesh, got {type(mesh).__name__}; wrap arrays as opnet.Mesh(vertices, faces)."
        )
    n = mesh.n_vertices
    if not isinstance(k, (int, np.integer)) or not 1 <= k <= n:
        raise ValueError(
            f"k must be an integer in [1, n={n}] for this mesh, got {k!r}; use a finer mesh for more eigenpairs."
        )
    k = int(k)
    total = mesh.area
    a = mesh.mass / total  # unit total area
    W = mesh.stiffness
    dense = k >= _DENSE_FRACTION * n or n < 200
    if dense and n > _DENSE_LIMIT:
        if k >= n - 1:
            raise ValueError(
                f"k={k} on a {n}-vertex mesh needs the dense solver (~{8 * n * n / 1e9:.0f} GB per n × n matrix); "
                f"ask for k <= {n - 2} or use a mesh with at most {_DENSE_LIMIT} vertices."
            )
        dense = False
    if not dense:
        # Shift-invert about a small negative shift: W + 1e-2 A is positive definite.
        v0 = np.linspace(1.0, 2.0, n)  # a fixed start vector makes ARPACK deterministic
        try:
            evals, evecs = scipy.sparse.linalg.eigsh(W, k=k, M=sp.diags(a), sigma=-1e-2, which="LM", v0=v0)
        except scipy.sparse.linalg.ArpackError as exc:
            if n > _DENSE_LIMIT:
                raise RuntimeError(
                    f"ARPACK did not converge for k={k} on this {n}-vertex mesh ({exc}); check the mesh quality "
                    "(very thin triangles) or ask for fewer eigenpairs."
                ) from None
            dense = True
        else:
            order = np.argsort(evals)
            evals, evecs = evals[order], evecs[:, order]
    if dense:
        evals, evecs = scipy.linalg.eigh(W.toarray(), np.diag(a), subset_by_index=[0, k - 1])
    evals = np.maximum(evals, 0.0) / total
    evecs = evecs / np.sqrt(total)
    evals[0] = 0.0
    evecs[:, 0] = 1.0 / np.sqrt(total)
    return Eigenbasis(mesh, evals, _fix_signs(evecs), mesh.mass)


# ---- batched weights for collections sharing one connectivity ---------------------------------------


def _cotan_weights(edges: list, double_area: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """:func:`cotan_edge_weights` from the faces' :func:`~opnet.mesh.face_edges` and :func:`~opnet.mesh.double_areas`.

    The cot of corner ``c`` is ``(e1 · e2) / |e1 × e2|`` with its two edges ``e1 = p[c+1] − p[c] = g[c+2]`` and
    ``e2 = p[c+2] − p[c] = −g[c+1]`` (``g`` the edges opposite the corners); each edge gets half the cots of the
    corners opposite it.
    """
    return _weights_of_cots(_corner_cots(edges, double_area), faces)


def _corner_cots(edges: list, double_area: np.ndarray) -> list:
    """The cots of the three corners, ``(..., m)`` each (see :func:`_cotan_weights`)."""
    return [-np.einsum("i...,i...->...", edges[(c + 2) % 3], edges[(c + 1) % 3]) / double_area for c in range(3)]


def _weights_of_cots(cots: list, faces: np.ndarray) -> np.ndarray:
    """Cotan weights ``(..., e)`` from the corners' cots: half of each to the edge opposite it."""
    cot = np.stack(cots, axis=-1)  # (..., m, 3): corner order, as the corner-to-edge matrix's rows
    return 0.5 * _scatter(cot.reshape(*cot.shape[:-2], -1), _corner_to_edge(faces))


def _lumped_areas(double_area: np.ndarray, faces: np.ndarray, n: int) -> np.ndarray:
    """:func:`vertex_areas` from :func:`~opnet.mesh.double_areas`: a third of each face's area to its corners."""
    return _scatter(double_area / 6.0, _face_incidence(faces, n))


def _corner_to_edge(faces: np.ndarray) -> sp.csr_matrix:
    """Sparse ``(3m, e)`` matrix adding each corner's value to its opposite edge (of ``unique_edges(faces)``)."""

    def build():
        edges = unique_edges(faces)
        col = corner_edges(faces, edges)
        return sp.csr_matrix((np.ones(len(col)), (np.arange(len(col)), col)), shape=(len(col), len(edges)))

    return _memo.by_content("corner to edge", (faces,), build)


def _scatter(values: np.ndarray, matrix: sp.spmatrix) -> np.ndarray:
    """``values @ matrix`` for values ``(..., p)`` and a sparse ``(p, q)`` matrix, giving ``(..., q)``."""
    flat = values.reshape(-1, values.shape[-1])
    return np.asarray(matrix.T @ flat.T).T.reshape(*values.shape[:-1], matrix.shape[1])


def _checked(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    vertices = real_array("vertices", vertices, (..., "n", 3))
    return vertices, as_faces(faces, vertices.shape[-2])


def cotan_edge_weights(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Cotan weights ``w_ij = (cot α + cot β) / 2`` ``(..., e)`` of the edges ``unique_edges(faces)``, in that order.

    ``vertices`` is ``(..., n, 3)``. The stiffness is ``W = Σ_e w_e (δ_i − δ_j)(δ_i − δ_j)ᵀ``. A torch tensor of
    vertices gives a tensor, differentiable in them.
    """
    if is_tensor(vertices):  # torch is imported by _backend only when a tensor comes
        return tensor_edge_weights(vertices, faces)
    vertices, faces = _checked(vertices, faces)
    edges = face_edges(vertices, faces)
    return _cotan_weights(edges, double_areas(edges), faces)


def vertex_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Barycentric lumped mass ``(..., n)`` (length²) for vertices ``(..., n, 3)`` sharing ``faces`` ``(m, 3)``.

    A torch tensor of vertices gives a tensor, differentiable in them (so an inner product written with it serves
    as its own ``project_torch``).
    """
    if is_tensor(vertices):
        return tensor_areas(vertices, faces)
    vertices, faces = _checked(vertices, faces)
    return _lumped_areas(double_areas(face_edges(vertices, faces)), faces, vertices.shape[-2])


def areas_and_cotan_weights(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`vertex_areas` ``(..., n)`` and :func:`cotan_edge_weights` ``(..., e)`` of numpy vertices ``(..., n, 3)``
    from one pass over their faces (the batched operators need both).
    """
    vertices, faces = _checked(vertices, faces)
    edges = face_edges(vertices, faces)
    double_area = double_areas(edges)
    return _lumped_areas(double_area, faces, vertices.shape[-2]), _cotan_weights(edges, double_area, faces)


def areas_weights_and_worst_quality(vertices: np.ndarray, faces: np.ndarray, weights: bool = True) -> tuple:
    """:func:`areas_and_cotan_weights` of checked float64 vertices ``(B, n, 3)`` and valid ``faces``, and each shape's
    worst :func:`~opnet.mesh.face_quality` ``(B,)`` from the same pass: a triangle's cots sum to ``Σ edge² / (4 area)``,
    so its quality ``4√3 · area / Σ edge²`` is ``√3 / Σ cot`` (0 for a collapsed one). For the fast path, which checks
    the shapes on the way (:func:`opnet.mesh.check_spans` first: at any other scale the products under- or overflow).
    Without ``weights`` the weights are ``None`` (their scatter onto the edges skipped).
    """
    edges = face_edges(vertices, faces)
    with np.errstate(divide="ignore", invalid="ignore"):  # collapsed faces: refused by the caller from the quality
        double_area = double_areas(edges)
        cots = _corner_cots(edges, double_area)
        worst = np.nan_to_num(np.sqrt(3.0) / (cots[0] + cots[1] + cots[2]), nan=0.0, posinf=0.0, neginf=0.0).min(-1)
        areas = _lumped_areas(double_area, faces, vertices.shape[-2])
        return areas, _weights_of_cots(cots, faces) if weights else None, worst


def _face_incidence(faces: np.ndarray, n: int) -> sp.csr_matrix:
    """Sparse ``(m, n)`` matrix of ones where face ``f`` has vertex ``i``: ``values @ it`` adds face values to the
    vertices of each face (:func:`_scatter`).
    """
    return _memo.by_content(
        f"face incidence {n}",
        (faces,),
        lambda: sp.csr_matrix(
            (np.ones(faces.size), (np.repeat(np.arange(len(faces)), 3), faces.ravel())), shape=(len(faces), n)
        ),
    )


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit vertex normals ``(..., n, 3)`` for vertices ``(..., n, 3)`` sharing ``faces`` ``(m, 3)``: at each vertex,
    the sum of its faces' normals weighted by their areas (``Σ (b − a) × (c − a)`` over its faces), normalised.

    Outward for a closed mesh whose faces are ordered counter-clockwise seen from outside. A torch tensor of
    vertices gives a tensor, differentiable in them.
    """
    if is_tensor(vertices):
        return tensor_normals(vertices, faces)
    vertices, faces = _checked(vertices, faces)
    cross = face_normals(face_edges(vertices, faces))  # (3, ..., m)
    summed = np.moveaxis(_scatter(cross, _face_incidence(faces, vertices.shape[-2])), 0, -1)  # (..., n, 3)
    return summed / np.maximum(np.linalg.norm(summed, axis=-1, keepdims=True), 1e-300)  # 0, not NaN, where none
