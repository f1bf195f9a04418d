"""Maps between the base and meshes of another triangulation, and the operators of any mesh through them.

The paper's training shapes share the base's connectivity, so their functional maps come from the
identity. Its "Comp" rows and its 5k-vertex reconstructions need maps between meshes with no known
correspondence. :func:`compute_map` computes one with pyFM (``pip install pyfmaps``), whose
conventions are opnet's: ``FM_12`` ``(k_mesh, k_base)`` carries base coefficients to the mesh's, like
:class:`opnet.FunctionalMap`, and ``p2p_21[p]`` is the base vertex of mesh vertex ``p``, like
:func:`opnet.fmap_from_p2p`.

1. Both eigenbases are opnet's (:func:`opnet.eigenbasis`), handed to pyFM's ``TriMesh``.
2. WKS descriptors, and a functional-map solve with descriptor preservation, Laplacian and
   descriptor commutativity, and the orientation-preserving term of Ren et al. (2018). A body is
   left–right symmetric and WKS cannot tell its sides apart: the term keeps a map from mirroring it.
3. ZoomOut (Melzi et al. 2019) from ``k_init`` to ``k`` functions.
4. A precise map (Ezuz & Ben-Chen 2017): each mesh vertex is projected onto a base triangle in the
   spectral embedding, giving barycentric coordinates: the sparse soft map ``to_base``
   ``(n_mesh, n_base)`` of a :class:`SurfaceMap`.

:func:`encode` turns a map into the shape differences against the base, through each inner
product's :meth:`~opnet.InnerProduct.pull_back`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ._deprecation import renamed_keyword
from ._extras import require
from .fmaps import FunctionalMap
from .inner_products import checked_gram, get_inner_products
from .mesh import Mesh, closest_points_on_faces, edge_face_counts, face_areas
from .metrics import mesh_volume
from .shape_difference import KINDS, base_pinvs, check_base, fast_path
from .spectral import Eigenbasis, eigenbasis

__all__ = [
    "SurfaceMap",
    "MapQualityWarning",
    "compute_map",
    "map_from_p2p",
    "closest_point_map",
    "encode",
    "operators_through_map",
]

#: The version of what :func:`compute_map` returns: bump it with any change to its output, so that operators
#: cached through computed maps (:func:`opnet.data.mapped_collection`) are computed again.
MAP_VERSION = 1
#: Below these, :func:`encode` warns that the map is probably wrong (see :meth:`SurfaceMap.quality`).
MIN_COVERAGE, MIN_ORIENTATION = 0.8, 0.5
# Candidate vertices per projected point: the faces around its 3 nearest vertices are tried.
_NEAR = 3


class MapQualityWarning(UserWarning):
    """A computed map that is probably wrong (it collapses, or reverses orientation)."""


@dataclass(frozen=True, eq=False)
class SurfaceMap:
    """A map from a mesh onto the base surface.

    Attributes
    ----------
    base : Eigenbasis
        The base's eigenbasis (``n_base`` vertices).
    mesh : Mesh
        The mapped mesh (``n_mesh`` vertices, its own triangulation).
    to_base : scipy.sparse.csr_matrix ``(n_mesh, n_base)``
        Row ``p``: barycentric coordinates of the base point that mesh vertex ``p`` maps to (at most
        three non-zeros, summing to 1; one for a vertex-to-vertex map).
    fmap : (k_mesh, k_base) array or None
        The functional map ``C`` the map was extracted from, in the two eigenbases (None when the map
        was given as vertices).
    """

    base: Eigenbasis
    mesh: Mesh
    to_base: sp.csr_matrix
    fmap: np.ndarray | None = None

    def __post_init__(self):
        check_base(self.base)
        _check_mesh(self.mesh)
        shape = (self.mesh.n_vertices, self.base.mesh.n_vertices)
        if not sp.issparse(self.to_base) or self.to_base.shape != shape:
            raise ValueError(
                f"to_base must be a scipy sparse matrix of shape (n_mesh, n_base) = {shape}, got "
                f"{type(self.to_base).__name__} of shape {getattr(self.to_base, 'shape', None)}."
            )
        object.__setattr__(self, "to_base", self.to_base.tocsr())

    @property
    def points(self) -> np.ndarray:
        """Where each mesh vertex lands on the base, ``(n_mesh, 3)`` in the base's coordinates."""
        return self.to_base @ self.base.mesh.vertices

    def quality(self) -> dict:
        """Two figures in [0, 1] that flag a wrong map without knowing the right one.

        ``coverage``
            The share of the base's area that receives at least a quarter of its own share of the mesh's
            area, once the carried area is smoothed over the base's eigenbasis. A map that collapses
            most points onto a few places leaves most of the base empty. A good map of a body: ≈ 1.
        ``orientation``
            The area-weighted share of mesh triangles whose image on the base turns the same way as the
            base surface there. A map onto the mirror image of a symmetric shape reverses it (≈ 0); a
            good map: well above 1/2 (noise jumbles small triangles).
        """
        base = self.base.mesh
        a = self.mesh.mass / self.mesh.area
        carried = self.to_base.T @ a  # the mesh's area on base vertices, summing to 1
        density = (self.base.evecs @ (self.base.evecs.T @ carried)) * base.area  # smoothed, ≈ 1 where even
        coverage = float(base.mass[density >= 0.25].sum() / base.area)
        normals = _vertex_normals(base.vertices, base.faces)
        image = self.points[_outward_faces(self.mesh)]  # (m, 3, 3)
        turned = np.cross(image[:, 1] - image[:, 0], image[:, 2] - image[:, 0])
        reference = (self.to_base @ normals)[self.mesh.faces].sum(1)
        weight = face_areas(self.mesh.vertices, self.mesh.faces)
        orientation = float(weight[np.einsum("fi,fi->f", turned, reference) > 0].sum() / weight.sum())
        return dict(coverage=coverage, orientation=orientation)

    def error(self, true_map: "SurfaceMap") -> np.ndarray:
        """Per mesh vertex, the straight-line distance between this map's image on the base and ``true_map``'s,
        ``(n_mesh,)``, in units of the base's ``sqrt(area)`` (Euclidean, not geodesic: equal for small errors,
        smaller for large ones).
        """
        if not isinstance(true_map, SurfaceMap) or true_map.base is not self.base:
            raise ValueError("true_map must be a SurfaceMap onto the same base_basis.")
        if true_map.mesh.n_vertices != self.mesh.n_vertices:
            raise ValueError("true_map maps another mesh; compare maps of the same mesh.")
        return np.linalg.norm(self.points - true_map.points, axis=1) / np.sqrt(self.base.mesh.area)


def _vertex_normals(vertices, faces) -> np.ndarray:
    """Area-weighted vertex normals ``(n, 3)`` (not normalised)."""
    cross = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    out = np.zeros_like(vertices)
    for j in range(3):
        np.add.at(out, faces[:, j], cross)
    return out


def _outward_faces(mesh: Mesh) -> np.ndarray:
    """The mesh's faces, turned to face outwards (reversed when its enclosed volume is negative)."""
    return mesh.faces if mesh_volume(mesh.vertices, mesh.faces) >= 0 else mesh.faces[:, ::-1]


def _barycentric_map(face, bary, faces, n_base) -> sp.csr_matrix:
    rows = np.repeat(np.arange(len(face)), 3)
    out = sp.csr_matrix((bary.ravel(), (rows, faces[face].ravel())), shape=(len(face), n_base))
    out.eliminate_zeros()
    return out


def _check_mesh(mesh, what="mesh") -> Mesh:
    if not isinstance(mesh, Mesh):
        raise TypeError(
            f"{what} must be an opnet.Mesh (opnet.Mesh(vertices, faces) or opnet.load_mesh(path)), "
            f"got {type(mesh).__name__}."
        )
    return mesh


def _check_closed(mesh: Mesh) -> None:
    _, counts = edge_face_counts(mesh.faces)
    if (counts == 1).any():
        raise ValueError(
            f"the mesh has {(counts == 1).sum()} boundary edges (holes); computed maps need a closed surface like "
            "the base's, since spectral descriptors change near a boundary. Close the holes first (e.g. "
            "trimesh.repair.fill_holes or pymeshfix), or pass a known vertex map as fmap=p2p."
        )


def map_from_p2p(base_basis: Eigenbasis, mesh: Mesh, p2p) -> SurfaceMap:
    """A :class:`SurfaceMap` from a known vertex map: ``p2p[p]`` is the base vertex of mesh vertex ``p``."""
    check_base(base_basis)
    mesh = _check_mesh(mesh)
    p2p = np.asarray(p2p)
    n, n0 = mesh.n_vertices, base_basis.mesh.n_vertices
    if p2p.shape != (n,) or p2p.dtype.kind not in "iu":
        raise ValueError(
            f"p2p must be an integer array of shape ({n},) (one base vertex per mesh vertex), "
            f"got {p2p.dtype} array of shape {p2p.shape}."
        )
    if n and (p2p.min() < 0 or p2p.max() >= n0):
        raise ValueError(f"p2p values must be base vertex indices in [0, {n0 - 1}], got [{p2p.min()}, {p2p.max()}].")
    return SurfaceMap(base_basis, mesh, sp.csr_matrix((np.ones(n), (np.arange(n), p2p)), shape=(n, n0)))


def closest_point_map(base_basis: Eigenbasis, mesh: Mesh) -> SurfaceMap:
    """Each mesh vertex onto the closest point of the base surface, in 3-D (among the faces around its three
    nearest base vertices).

    Right for two triangulations of one shape in one place (the generator's 1k, 2k and 5k meshes of
    the base, say): it is the true map that computed maps are measured against.
    """
    check_base(base_basis)
    mesh = _check_mesh(mesh)
    base = base_basis.mesh
    _, near = cKDTree(base.vertices).query(mesh.vertices, k=_NEAR)
    face, bary = closest_points_on_faces(mesh.vertices, base.vertices, base.faces, near)
    return SurfaceMap(base_basis, mesh, _barycentric_map(face, bary, base.faces, base.n_vertices))


def _pyfm_mesh(basis: Eigenbasis):
    m = require("pyFM.mesh", "opnet.matching").TriMesh(np.array(basis.mesh.vertices), np.array(basis.mesh.faces))
    m.eigenvalues, m.eigenvectors = basis.evals, basis.evecs
    m.mass, m.stiffness = sp.diags(basis.mass).tocsc(), basis.mesh.stiffness
    return m


def compute_map(
    base_basis: Eigenbasis,
    mesh: Mesh,
    *,
    k: int = 100,
    k_init: int = 20,
    orientation: bool = True,
    base_spectrum: Eigenbasis | None = None,
) -> SurfaceMap:
    """A map from ``mesh`` (any triangulation, any vertex order) onto the base, by functional maps.

    Parameters
    ----------
    base_basis : Eigenbasis
        The base's eigenbasis (the one the operators use).
    mesh : Mesh
        A closed surface of the base's kind (a body for the human base), placed, scaled and oriented
        anyhow: it is matched at the base's total area, with its faces turned outwards.
    k : int
        Functions on each side at the end of ZoomOut (100 is about where the map stops improving
        on the 1k-vertex human base).
    k_init : int
        Size of the first, descriptor-based, solve.
    orientation : bool
        Use the orientation-preserving term (needed for left–right symmetric shapes).
    base_spectrum : Eigenbasis, optional
        The base's first ``k`` eigenpairs, when mapping many meshes (computed when omitted).

    Returns
    -------
    SurfaceMap
        With ``fmap`` the ``(k, k)`` functional map from ZoomOut.
    """
    check_base(base_basis)
    mesh = _check_mesh(mesh)
    _check_closed(mesh)
    if not isinstance(k, (int, np.integer)) or not isinstance(k_init, (int, np.integer)) or not 2 <= k_init <= k:
        raise ValueError(f"k_init and k must be integers with 2 <= k_init <= k, got k_init={k_init!r}, k={k!r}.")
    n_max = min(mesh.n_vertices, base_basis.mesh.n_vertices) - 1
    if k > n_max:
        raise ValueError(
            f"k={k} functions need meshes of more than {k} vertices; the smaller has {n_max + 1}. Pass a smaller k."
        )
    FunctionalMapping = require("pyFM.functional", "opnet.matching").FunctionalMapping
    knn_query = require("pyFM.spectral.nearest_neighbor.dispatch", "opnet.matching").knn_query

    spectrum = base_spectrum if base_spectrum is not None else eigenbasis(base_basis.mesh, k)
    if spectrum.mesh is not base_basis.mesh or spectrum.k < k:
        raise ValueError(f"base_spectrum must be eigenbasis(base_basis.mesh, k) with at least k={k} functions.")
    spectrum = spectrum.truncate(k)
    scale = np.sqrt(base_basis.mesh.area / mesh.area)  # descriptors and the solve's weights depend on scale
    target = eigenbasis(Mesh(mesh.vertices * scale, _outward_faces(mesh)), k)
    problem = FunctionalMapping(_pyfm_mesh(spectrum), _pyfm_mesh(target))
    problem.preprocess(n_descr=100, descr_type="WKS", k_process=k, subsample_step=5, k_descr=k)
    problem.fit(K=(k_init, k_init), w_descr=1.0, w_lap=1e-2, w_dcomm=1e-1, w_orient=1.0 if orientation else 0.0)
    C = problem.FM_12
    step = 4
    for nit, size in (((k - k_init) // step, step), (1, (k - k_init) % step)):  # ZoomOut ends at exactly k
        if nit and size:
            C = problem.zoomout_refine(C, nit=nit, step=size)
    C = np.asarray(C)
    # the precise map (adjoint form): mesh vertex p ↦ a point of a base triangle, in the spectral embedding
    base_emb, mesh_emb = spectrum.evecs[:, : C.shape[1]], target.evecs[:, : C.shape[0]] @ C
    near = knn_query(base_emb, mesh_emb, k=_NEAR)
    base = base_basis.mesh
    face, bary = closest_points_on_faces(mesh_emb, base_emb, base.faces, near)
    return SurfaceMap(base_basis, mesh, _barycentric_map(face, bary, base.faces, base.n_vertices), C)


@renamed_keyword("kinds", "channels")
def operators_through_map(surface_map, channels=KINDS) -> np.ndarray:
    """Shape differences ``(len(channels), k, k)`` of ``surface_map.mesh`` against the base, through the map; for a
    list of maps onto one base, ``(len(maps), len(channels), k, k)`` (the base's ``K_0⁺`` computed once).

    ``D = K_0⁺ K`` with ``K`` each inner product of the mesh pulled back onto the base's functions
    (:meth:`opnet.InnerProduct.pull_back`). With the identity map this is the fast path exactly.
    """
    single = isinstance(surface_map, SurfaceMap)
    maps = [surface_map] if single else list(surface_map) if isinstance(surface_map, (list, tuple)) else None
    if not maps or not all(isinstance(sm, SurfaceMap) for sm in maps):
        raise TypeError(
            "surface_map must be an opnet.matching.SurfaceMap or a non-empty list of them, got "
            f"{type(surface_map).__name__}."
        )
    basis = maps[0].base
    if any(sm.base is not basis for sm in maps):
        raise ValueError("the maps go onto different bases; encode them one base at a time.")
    ips = get_inner_products(channels)
    pinvs = base_pinvs(basis, ips)
    out = np.stack(
        [
            np.stack(
                [
                    k0_pinv @ checked_gram(ip, "pull_back", sm.mesh.vertices, sm.mesh.faces, sm.to_base, basis.evecs)
                    for ip, k0_pinv in zip(ips, pinvs)
                ]
            )
            for sm in maps
        ]
    )
    return out[0] if single else out


@renamed_keyword("kinds", "channels")
def encode(mesh: Mesh, base_basis, *, fmap=None, channels=None, warn: bool = True, **map_options) -> np.ndarray:
    """The shape differences ``(len(channels), k, k)`` of any mesh against the base: OperatorNet's input.

    Parameters
    ----------
    mesh : Mesh
        The shape (e.g. ``opnet.load_mesh(path)``).
    base_basis : Eigenbasis or Collection
        The base's eigenbasis (a collection's ``base_basis``), or the collection itself
        (:class:`opnet.data.Collection`), whose base and channels it then encodes against.
    fmap : None, "computed", array or SurfaceMap
        How the mesh corresponds to the base. ``None``: it has the base's triangulation (same faces),
        and the fast path is used. ``"computed"``: no correspondence is known, :func:`compute_map` finds
        one (``map_options`` go to it). An integer array ``(n_mesh,)``: the base vertex of each mesh
        vertex. A :class:`SurfaceMap`: a map already computed.
    channels : sequence of channels, optional
        The channels to encode, in order (names, inner products). Default: those of the collection given as
        ``base_basis`` (all of its :attr:`~opnet.data.Collection.channels`, in its order: what a network trained on
        it reads by default, so ``opnet.decode(net, opnet.encode(mesh, collection))`` names no channels); with an
        eigenbasis, the paper's three (:data:`opnet.KINDS`). A collection computes its channels with the inner
        products it holds (:meth:`~opnet.data.Collection.inner_products`: a channel of your own read back from disk
        needs its instance or registration).
    warn : bool
        Warn (:class:`MapQualityWarning`) when a computed map looks wrong: it collapses (coverage below
        0.8) or reverses orientation (below 0.5). See :meth:`SurfaceMap.quality`.
    """
    if hasattr(base_basis, "base_basis") and hasattr(base_basis, "inner_products"):  # a collection (duck-typed)
        collection, base_basis = base_basis, base_basis.base_basis
        check_base(base_basis)
        ips = collection.inner_products(channels)  # None: all of its channels, in its order
    else:
        check_base(base_basis)
        ips = get_inner_products(KINDS if channels is None else channels)
    mesh = _check_mesh(mesh)
    base = base_basis.mesh
    if map_options and not (isinstance(fmap, str) and fmap == "computed"):
        raise TypeError(f"{sorted(map_options)} apply only to fmap='computed'.")
    if fmap is None:
        if mesh.n_vertices != base.n_vertices or not np.array_equal(mesh.faces, base.faces):
            raise ValueError(
                f"fmap=None needs the base's triangulation ({base.n_vertices} vertices, the same faces), but this mesh "
                f"has {mesh.n_vertices} vertices{'' if mesh.n_vertices != base.n_vertices else ' and other faces'}: "
                "pass fmap='computed' to compute a map, or fmap=p2p if you know each vertex's base vertex."
            )
        return fast_path(base_basis, mesh.vertices[None], ips)[0]  # the mesh is checked
    if isinstance(fmap, str):
        if fmap != "computed":
            raise ValueError(f"fmap must be None, 'computed', an integer vertex map or a SurfaceMap, got {fmap!r}.")
        fmap = compute_map(base_basis, mesh, **map_options)
        if warn:
            _warn_if_poor(fmap)
    elif isinstance(fmap, FunctionalMap):
        raise TypeError(
            "encode takes a point correspondence (fmap='computed', a vertex map or an "
            "opnet.matching.SurfaceMap), not an opnet.FunctionalMap; for a functional map use "
            "opnet.shape_difference(base_basis, mesh, kind, fmap=...)."
        )
    elif isinstance(fmap, SurfaceMap):
        if fmap.base is not base_basis or fmap.mesh is not mesh:
            raise ValueError("this SurfaceMap maps another mesh or base; compute it for this mesh and base_basis.")
    else:
        fmap = map_from_p2p(base_basis, mesh, fmap)
    return operators_through_map(fmap, ips)


def _warn_if_poor(surface_map: SurfaceMap) -> None:
    q = surface_map.quality()
    ratio = surface_map.mesh.area / surface_map.base.mesh.area
    problems = []
    if q["coverage"] < MIN_COVERAGE:
        problems.append(f"it covers only {q['coverage']:.0%} of the base (it collapses)")
    if q["orientation"] < MIN_ORIENTATION:
        problems.append(f"it keeps the orientation of only {q['orientation']:.0%} of the surface (a mirror image?)")
    if problems:
        warnings.warn(
            f"the computed map is probably wrong: {'; '.join(problems)}. The mesh may not be of the base's kind "
            f"(its area is {ratio:.2g}× the base's), or its faces are not consistently oriented. Check "
            "opnet.matching.compute_map(...).quality(), or pass a known vertex map as fmap=p2p.",
            MapQualityWarning,
            stacklevel=3,
        )
