"""Inner products on vertex functions, expressed in a basis: ``K = Φᵀ M Φ``.

A shape difference (eq. 2 of the paper) needs one thing from an inner product: the
``k × k`` matrix ``K = Φᵀ M Φ`` of some positive semi-definite operator ``M`` on the
mesh's vertex functions, for a basis ``Φ`` ``(n, k)``. Subclass :class:`InnerProduct`
and implement :meth:`InnerProduct.project` to add a new one::

    class Gram(opnet.InnerProduct):
        name = "gram"
        def project(self, vertices, faces, evecs):
            F = evecs.T @ (opnet.vertex_areas(vertices, faces)[:, None] * vertices)
            return F @ F.T

Override :meth:`InnerProduct.project_batch` as well when a vectorised form over many
shapes with the same faces exists (the three built-ins do), and :meth:`InnerProduct.pull_back` when
the inner product has a better form on a mesh of another triangulation than the default
``(P Φ)ᵀ M (P Φ)`` (area and extrinsic lump their masses, as the fast path does).
"""

from __future__ import annotations

import numpy as np

from ._checks import describe
from .mesh import unique_edges
from .spectral import _edge_weights, _vertex_areas

__all__ = [
    "InnerProduct",
    "AreaInnerProduct",
    "ConformalInnerProduct",
    "ExtrinsicInnerProduct",
    "INNER_PRODUCTS",
    "get_inner_product",
    "get_inner_products",
    "checked_gram",
]


# Entries of the column-product table built at once in the batched product (bounds its memory to ~32 MB).
_TABLE_ENTRIES = 4_000_000


def _weighted_gram(evecs: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``Φᵀ diag(w) Φ`` for weights ``(..., n)``, giving ``(..., k, k)``.

    For a batch of weight vectors the product is linear in ``w``: it is one matrix product
    ``w @ T`` with the table ``T[p, (i, j)] = Φ[p, i] Φ[p, j]`` (upper triangle, built in
    chunks of vertices), which runs several times faster than one product per shape.
    """
    if weights.ndim == 1:
        return evecs.T @ (weights[:, None] * evecs)
    k = evecs.shape[1]
    iu, ju = np.triu_indices(k)
    flat = weights.reshape(-1, weights.shape[-1])
    upper = np.zeros((len(flat), len(iu)))
    step = max(1, _TABLE_ENTRIES // len(iu))
    for s in range(0, evecs.shape[0], step):
        rows = evecs[s : s + step]
        upper += flat[:, s : s + step] @ (rows[:, iu] * rows[:, ju])
    out = np.empty((len(flat), k, k))
    out[:, iu, ju] = upper
    out[:, ju, iu] = upper
    return out.reshape(*weights.shape[:-1], k, k)


class InnerProduct:
    """An inner product ``⟨f, g⟩ = fᵀ M g`` on vertex functions, one per shape.

    Subclasses set :attr:`name` and implement :meth:`project`.
    """

    name = "custom"

    def project(self, vertices: np.ndarray, faces: np.ndarray, evecs: np.ndarray) -> np.ndarray:
        """``Φᵀ M Φ`` ``(k, k)`` for one shape: vertices ``(n, 3)``, faces ``(m, 3)``, ``Φ`` ``(n, k)``.

        ``M`` is the operator of this inner product on that shape; ``Φ`` may be any
        basis of vertex functions on it (its own eigenbasis or the base's one).
        """
        raise NotImplementedError(f"{type(self).__name__} must implement project(vertices, faces, evecs).")

    def project_batch(self, vertices: np.ndarray, faces: np.ndarray, evecs: np.ndarray) -> np.ndarray:
        """``Φᵀ M_b Φ`` ``(B, k, k)`` for shapes ``(B, n, 3)`` sharing ``faces``; loops :meth:`project` by default."""
        return np.stack([self.project(v, faces, evecs) for v in vertices])

    def pull_back(self, vertices: np.ndarray, faces: np.ndarray, to_base, evecs: np.ndarray) -> np.ndarray:
        """``(P Φ)ᵀ M (P Φ)`` ``(k, k)``: this inner product of a mesh with another triangulation, on base functions.

        ``vertices`` ``(n_mesh, 3)`` and ``faces`` are the mesh's, ``Φ`` ``(n_base, k)`` base functions and
        ``P`` ``(n_mesh, n_base)`` a soft map (row-stochastic, e.g. barycentric): mesh vertex ``p`` lies at
        the base point ``P[p] @ base_vertices``, so ``P Φ`` are the base functions carried onto the mesh.
        This is the paper's ``Cᵀ K_i C`` with a full target basis (``C = Φ_iᵀ A_i P Φ_0``), and the fast path
        when ``P`` is the identity.
        """
        return self.project(vertices, faces, to_base @ evecs)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


class AreaInnerProduct(InnerProduct):
    """The ``L²`` inner product, ``M = A`` (lumped mass). In a shape's own basis ``K = I``."""

    name = "area"

    def project(self, vertices, faces, evecs):
        return _weighted_gram(evecs, _vertex_areas(vertices, faces))

    project_batch = project

    def pull_back(self, vertices, faces, to_base, evecs):
        """The mesh's lumped masses carried onto the base vertices, ``Φᵀ diag(Pᵀ a) Φ``.

        This is ``(P Φ)ᵀ A (P Φ)`` lumped by rows, as the fast path's mass is lumped; it is exact for
        the identity map and, unlike the unlumped form, does not shrink the high frequencies that a
        barycentric ``P`` averages.
        """
        return _weighted_gram(evecs, to_base.T @ _vertex_areas(vertices, faces))


class ConformalInnerProduct(InnerProduct):
    """The ``H¹`` (Dirichlet) inner product, ``M = W`` (cotan stiffness). In a shape's own basis ``K = Λ``."""

    name = "conformal"

    def project(self, vertices, faces, evecs):
        edges = unique_edges(faces)
        diff = evecs[edges[:, 0]] - evecs[edges[:, 1]]  # (e, k)
        return _weighted_gram(diff, _edge_weights(vertices, faces, edges))

    project_batch = project


class ExtrinsicInnerProduct(InnerProduct):
    """The paper's extrinsic inner product ``M = E^D`` (eq. 7; the difference is eq. 8).

    ``E(i, j) = ‖v_i − v_j‖² A_i A_j`` and ``E^D = diag(E 1) − E`` is the Laplacian of the
    complete graph with weights ``E``. Since ``E = u aᵀ + a uᵀ − 2 Y Yᵀ`` with
    ``u = A|v|²`` and ``Y = A v`` (rank ≤ 5), ``Φᵀ E^D Φ`` costs ``O(n k²)`` and no
    ``n × n`` matrix is formed.
    """

    name = "extrinsic"

    def project(self, vertices, faces, evecs):
        return _extrinsic_gram(evecs, _vertex_areas(vertices, faces), vertices)

    project_batch = project

    def pull_back(self, vertices, faces, to_base, evecs):
        """Lumped, like the area's: masses ``Pᵀ a`` on the base vertices, at the mass-weighted mean position
        of the mesh points that land around each (a base vertex that receives no mass has no weight).

        Unlike the area's, this is an approximation of ``(P Φ)ᵀ E^D (P Φ)``: the spread of the positions
        around each mean is dropped. It is exact for the identity map.
        """
        a = _vertex_areas(vertices, faces)
        mass = to_base.T @ a
        moment = to_base.T @ (a[:, None] * vertices)
        where = mass > 0
        positions = np.zeros_like(moment)
        positions[where] = moment[where] / mass[where, None]
        return _extrinsic_gram(evecs, mass, positions)


def _extrinsic_gram(evecs: np.ndarray, a: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """``Φᵀ E^D Φ`` for masses ``a`` ``(..., n)`` at positions ``(..., n, 3)`` (the extrinsic inner product)."""
    # distances are translation invariant: centring first avoids cancellation
    v = vertices - (a[..., None] * vertices).sum(-2, keepdims=True) / a.sum(-1)[..., None, None]
    u = a * np.einsum("...ni,...ni->...n", v, v)
    y = a[..., None] * v  # (..., n, 3)
    rowsum = (
        u * a.sum(-1, keepdims=True) + a * u.sum(-1, keepdims=True) - 2 * np.einsum("...ni,...i->...n", y, y.sum(-2))
    )
    pa, pu, py = evecs.T @ a[..., None], evecs.T @ u[..., None], evecs.T @ y  # (..., k, 1|3)
    low_rank = pu @ np.swapaxes(pa, -1, -2) + pa @ np.swapaxes(pu, -1, -2) - 2 * py @ np.swapaxes(py, -1, -2)
    return _weighted_gram(evecs, rowsum) - low_rank


def get_inner_products(kinds) -> list[InnerProduct]:
    """The inner products of a non-empty sequence of kinds (each as in :func:`get_inner_product`)."""
    if isinstance(kinds, (str, InnerProduct)):
        raise TypeError(f"kinds must be a sequence of kinds, e.g. ({kinds!r},), not a single one.")
    ips = [get_inner_product(kind) for kind in kinds]
    if not ips:
        raise ValueError("kinds is empty: ask for at least one of opnet.KINDS (or an InnerProduct).")
    return ips


def checked_gram(ip: InnerProduct, method: str, *args) -> np.ndarray:
    """``ip.<method>(*args)`` (``"project"``, ``"project_batch"`` or ``"pull_back"``), checked: a real, finite,
    symmetric ``(k, k)`` matrix (``(B, k, k)`` for a batch), ``k`` the number of basis functions (the last
    argument's columns). A user-defined inner product that returns anything else is named in the error.
    """
    evecs = args[-1]
    shape = (len(args[0]), evecs.shape[1], evecs.shape[1]) if method == "project_batch" else (evecs.shape[1],) * 2
    K = getattr(ip, method)(*args)
    where = f"{type(ip).__name__}.{method} (inner product {ip.name!r})"
    if not isinstance(K, np.ndarray) or K.dtype.kind not in "fiu" or K.shape != shape:
        raise ValueError(
            f"{where} returned {describe(K)}; it must return Φᵀ M Φ, a real array of shape {shape} "
            f"(k = {shape[-1]} basis functions: evecs.shape[1])."
        )
    if not np.isfinite(K).all():
        raise ValueError(f"{where} returned NaN or infinite values; check the operator M on this shape.")
    scale = np.abs(K).max(axis=(-2, -1), keepdims=True)
    if np.any(np.abs(K - np.swapaxes(K, -1, -2)) > 1e-8 * scale):
        raise ValueError(
            f"{where} returned a non-symmetric matrix; Φᵀ M Φ of an inner product is symmetric "
            "(symmetrise M, e.g. (M + Mᵀ) / 2)."
        )
    return K


#: The paper's three inner products by name: what a ``kind`` string (``"area"``, ``"conformal"``,
#: ``"extrinsic"``) stands for.
INNER_PRODUCTS = {ip.name: ip for ip in (AreaInnerProduct(), ConformalInnerProduct(), ExtrinsicInnerProduct())}


def get_inner_product(kind) -> InnerProduct:
    """``"area"``, ``"conformal"``, ``"extrinsic"`` or an :class:`~opnet.inner_products.InnerProduct` instance."""
    if isinstance(kind, InnerProduct):
        return kind
    if isinstance(kind, type) and issubclass(kind, InnerProduct):
        return kind()
    try:
        return INNER_PRODUCTS[kind]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown shape-difference kind {kind!r}; use one of {sorted(INNER_PRODUCTS)} or an opnet.InnerProduct "
            "instance."
        ) from None
