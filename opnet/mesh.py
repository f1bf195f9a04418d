"""Triangle meshes: validated construction, loading, and per-vertex geometry.

A :class:`Mesh` holds float64 vertex coordinates ``(n, 3)`` and int64 faces
``(m, 3)``. Construction checks everything the spectral code relies on and
raises :class:`MeshError` with a message that names the problem and the fix.
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

import numpy as np
import potpourri3d as pp3d
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from . import _memo
from ._checks import real_array, warn_user
from ._parallel import thread_map

__all__ = [
    "Mesh",
    "MeshError",
    "MeshWarning",
    "face_quality",
    "check_shapes",
    "check_spans",
    "report_quality",
    "span",
    "load_mesh",
    "unique_edges",
    "corner_edges",
    "edge_face_counts",
    "face_areas",
    "face_edges",
    "face_normals",
    "double_areas",
    "squared_norms",
    "farthest_first",
    "furthest_vertices",
    "vertex_faces",
    "closest_points_on_faces",
    "components",
]

_LOADABLE = (".ply", ".obj", ".off", ".stl")


class MeshError(ValueError):
    """A mesh that the operators cannot be built on; the message says how to fix it."""


def farthest_first(distance_to, n: int) -> np.ndarray:
    """Greedy farthest-first traversal: indices of up to ``n`` distinct items, starting from item 0.

    ``distance_to(i)`` returns the distances ``(N,)`` from item ``i`` to every item; each new item is the one
    furthest from those already chosen. Stops early when only copies of chosen items remain (distance 0).
    """
    chosen = [0]
    nearest = np.asarray(distance_to(0), dtype=np.float64)
    while len(chosen) < min(n, len(nearest)) and nearest.max() > 0:
        nxt = int(np.argmax(nearest))
        chosen.append(nxt)
        nearest = np.minimum(nearest, distance_to(nxt))
    return np.array(chosen)


def furthest_vertices(vertices, n: int) -> np.ndarray:
    """Indices of ``n`` vertices ``(n_vertices, 3)`` spread over the shape by farthest-first sampling (Euclidean)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    return farthest_first(lambda i: np.linalg.norm(vertices - vertices[i], axis=1), n)


def vertex_faces(faces: np.ndarray, n: int) -> np.ndarray:
    """The faces around each vertex, ``(n, max_degree)`` int64 padded with ``-1``."""
    corner_vertex = faces.ravel()
    order = np.argsort(corner_vertex, kind="stable")
    counts = np.bincount(corner_vertex, minlength=n)
    slot = np.arange(faces.size) - np.repeat(np.cumsum(counts) - counts, counts)
    table = np.full((n, max(int(counts.max()), 1)), -1, dtype=np.int64)
    table[corner_vertex[order], slot] = order // 3
    return table


def closest_points_on_faces(
    points: np.ndarray, vertices: np.ndarray, faces: np.ndarray, near: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The closest point to each of ``points`` ``(m, d)`` among the faces around its ``near`` vertices.

    ``vertices`` ``(n, d)`` may live in any dimension ``d`` (3-D space, or a spectral embedding); ``near``
    ``(m, r)`` are, for each point, ``r`` mesh vertices close to it (e.g. its nearest ones), whose faces are
    the candidates. Returns the face ``(m,)`` and barycentric coordinates ``(m, 3)`` of each closest point.
    Every candidate triangle is solved exactly (interior, else the nearest of its three edges), all points
    at once: pyFM's ``project_pc_to_triangles`` does the same one point at a time.
    """
    points, near = np.asarray(points, dtype=np.float64), np.asarray(near)
    if (
        points.ndim != 2
        or points.shape[1] != np.shape(vertices)[1]
        or near.dtype.kind not in "iu"
        or near.shape[:1] != points.shape[:1]
    ):
        raise ValueError(
            f"points must be (m, d) with d = {np.shape(vertices)[1]} and near (m, r) integer vertex "
            f"indices, got {points.shape} and {near.dtype} {near.shape}."
        )
    table = vertex_faces(faces, len(vertices))
    near = near.reshape(len(points), -1)
    chunk = max(1, 2**22 // (3 * table.shape[1] * near.shape[1] * max(points.shape[1], 1)))  # ~32 MB per array
    parts = []
    for s in range(0, len(points), chunk):
        cand = table[near[s : s + chunk]].reshape(len(near[s : s + chunk]), -1)  # (m, c) candidate faces
        parts.append(_closest_in(points[s : s + chunk], vertices, faces, cand))
    if not parts:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def _closest_in(points, vertices, faces, cand):
    """:func:`closest_points_on_faces` for one chunk, with candidate faces ``cand`` ``(m, c)`` (``-1``: none)."""
    valid = cand >= 0
    cand = np.where(valid, cand, cand[:, :1])
    corners = [vertices[faces[cand, j]] for j in range(3)]  # 3 × (m, c, d)
    x = points[:, None, :]
    a, b, c = corners
    e0, e1, rel = b - a, c - a, x - a
    g00, g01, g11 = (e0 * e0).sum(-1), (e0 * e1).sum(-1), (e1 * e1).sum(-1)
    r0, r1 = (e0 * rel).sum(-1), (e1 * rel).sum(-1)
    det = np.maximum(g00 * g11 - g01**2, np.finfo(float).tiny)
    s, t = (g11 * r0 - g01 * r1) / det, (g00 * r1 - g01 * r0) / det
    bary = np.stack([1 - s - t, s, t], -1)
    inside = (s >= 0) & (t >= 0) & (s + t <= 1)
    dist = np.where(inside, np.sum((rel - s[..., None] * e0 - t[..., None] * e1) ** 2, -1), np.inf)
    for i, j in ((0, 1), (1, 2), (2, 0)):  # the edges, for points whose projection falls outside
        d = corners[j] - corners[i]
        u = np.clip(np.sum((x - corners[i]) * d, -1) / np.maximum((d * d).sum(-1), np.finfo(float).tiny), 0, 1)
        du = np.sum((x - corners[i] - u[..., None] * d) ** 2, -1)
        better = du < dist
        edge = np.zeros_like(bary)
        edge[..., i], edge[..., j] = 1 - u, u
        bary = np.where(better[..., None], edge, bary)
        dist = np.where(better, du, dist)
    best = np.where(valid, dist, np.inf).argmin(1)
    rows = np.arange(len(points))
    return cand[rows, best], bary[rows, best]


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Triangle areas, ``(..., m)`` for vertices ``(..., n, 3)`` and faces ``(m, 3)``."""
    return 0.5 * double_areas(face_edges(vertices, faces))


def face_edges(vertices: np.ndarray, faces: np.ndarray) -> list:
    """The edge opposite each corner ``c`` of every face, ``p[c + 2] − p[c + 1]``: three arrays ``(3, ..., m)``,
    coordinate first (x, y, z rows), for vertices ``(..., n, 3)``. In this layout every arithmetic step of the
    batched geometry runs on contiguous rows (several times faster than on the interleaved ``(..., m, 3)``).
    """
    x = np.ascontiguousarray(np.moveaxis(vertices, -1, 0))  # (3, ..., n): a gather from a view is 3× slower
    p = [np.take(x, faces[:, c], axis=-1) for c in range(3)]
    return [p[2] - p[1], p[0] - p[2], p[1] - p[0]]


def face_normals(edges: list) -> np.ndarray:
    """``(b − a) × (c − a)`` ``(3, ..., m)`` (coordinate first), each face's normal times twice its area, from
    :func:`face_edges`.
    """
    a, b = edges[1], edges[2]  # (p₀ − p₂) × (p₁ − p₀) = (p₁ − p₀) × (p₂ − p₀)
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def double_areas(edges: list) -> np.ndarray:
    """``|(b − a) × (c − a)|`` ``(..., m)``, twice each face's area, from :func:`face_edges`."""
    return np.sqrt(squared_norms(face_normals(edges)))


def squared_norms(vectors: np.ndarray) -> np.ndarray:
    """``|v|²`` ``(...)`` of coordinate-first vectors ``(3, ...)`` (:func:`face_edges`' layout)."""
    return np.einsum("i...,i...->...", vectors, vectors)


# A triangle's quality q = 4√3 · area / (sum of its squared edge lengths): 1 for an equilateral triangle, 0 for
# a collapsed one, the same at every scale. Its cotan weights grow like 1/q: thinning one face of the toy capsule
# to quality q changes its conformal operator by ≈ 0.015 / q (relative Frobenius; ≈ 0.004 / q on the toy finger),
# so below WARN_QUALITY one face outweighs the whole shape many times, and below REFUSE_QUALITY the weights are
# noise. The generated shapes stay above it: q ≥ 1.2e-3 (humans, quick and default), 4e-3 (heads), 8.8e-4 (hands).
WARN_QUALITY = 1e-4
REFUSE_QUALITY = 1e-8
# Bounding-box diagonals outside this range under/overflow float64 areas and the extrinsic operator (∝ length⁶).
SPAN_RANGE = (1e-40, 1e40)


class MeshWarning(UserWarning):
    """A mesh that the operators can be built on, but badly (e.g. near-degenerate faces); the message says why."""


def span(vertices: np.ndarray) -> np.ndarray:
    """Bounding-box diagonal ``(...)`` of shapes ``(..., n, 3)`` (length unit), without overflow at any scale."""
    # (..., 3): inf only beyond the dtype's range, out of range anyway; a coordinate at a time, along the contiguous
    # rows (a reduction over the middle axis of (..., n, 3) is 20× slower: 66 against 3 µs a 1k-vertex shape)
    extent = np.stack([vertices[..., c].max(-1) - vertices[..., c].min(-1) for c in range(3)], axis=-1)
    scale = extent.max(-1, keepdims=True)
    with np.errstate(invalid="ignore"):  # an infinite extent: inf / inf; its span is inf
        unit = extent / np.where(scale > 0, scale, 1.0)  # in [0, 1]: its norm cannot overflow
    return np.where(np.isinf(scale[..., 0]), np.inf, scale[..., 0] * np.linalg.norm(unit, axis=-1))


def face_quality(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Scale-free triangle quality ``4√3 · area / Σ edge²`` ``(..., m)``: 1 equilateral, 0 collapsed.

    Computed on each shape ``(..., n, 3)`` divided by its largest coordinate, so that it neither under- nor
    overflows at extreme scales; a shape whose vertices all coincide has quality 0.
    """
    scale = np.abs(vertices).max(axis=(-2, -1), keepdims=True)
    return _quality(vertices / np.where(scale > 0, scale, 1.0), faces)


def _quality(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """:func:`face_quality` of shapes whose span is within ``SPAN_RANGE`` (no rescaling needed)."""
    edges = face_edges(vertices, faces)
    edges2 = sum(map(squared_norms, edges))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.nan_to_num(2 * np.sqrt(3) * double_areas(edges) / edges2)


def _out_of_range(spans: np.ndarray) -> np.ndarray:
    """Which spans lie outside ``SPAN_RANGE`` (0, all vertices in one point, is left to the quality check)."""
    return ((spans > 0) & (spans < SPAN_RANGE[0])) | (spans > SPAN_RANGE[1])


def check_shapes(name: str, vertices: np.ndarray, faces: np.ndarray, *, batch_size: int = 64) -> np.ndarray:
    """Refuse shapes ``(B, n, 3)`` sharing ``faces`` whose scale is out of range or that have collapsed faces
    (``ValueError`` naming ``name`` and the first shape), and warn (:class:`MeshWarning`) about near-degenerate
    ones. The faces are checked ``batch_size`` shapes at a time, one batch per core (the triangles of a whole
    collection take gigabytes). :func:`check_spans` and :func:`report_quality` are its two halves. Returns each
    shape's worst face quality ``(B,)``.
    """
    batches = range(0, len(vertices), batch_size)
    check_spans(name, vertices)
    # elementwise numpy: no BLAS to hold
    worst = thread_map(lambda s: _quality(vertices[s : s + batch_size], faces).min(-1), batches, hold_blas=False)
    quality = np.concatenate([np.zeros(0), *worst])
    report_quality(name, quality)
    return quality


def check_spans(name: str, vertices: np.ndarray) -> None:
    """Refuse shapes ``(B, n, 3)`` whose bounding-box diagonal lies outside ``SPAN_RANGE`` (``ValueError``)."""
    spans = span(vertices)
    bad = _out_of_range(spans)
    if bad.any():
        i = np.flatnonzero(bad)[0]
        raise ValueError(
            f"{name}: {bad.sum()} shapes span a bounding-box diagonal outside {list(SPAN_RANGE)} length "
            f"units (first: shape {i}, {spans[i]:.3g}), where float64 areas and the extrinsic operator "
            "under- or overflow; rescale the coordinates."
        )


def report_quality(name: str, quality: np.ndarray) -> None:
    """Refuse (``ValueError``) shapes whose worst face quality ``quality`` ``(B,)`` is below ``REFUSE_QUALITY``,
    and warn (:class:`MeshWarning`) about those below ``WARN_QUALITY``, naming ``name`` and the first shape.
    """
    for what, limit in (("zero-area (collapsed)", REFUSE_QUALITY), ("near-degenerate", WARN_QUALITY)):
        low = quality < limit
        if low.any():
            i = np.flatnonzero(low)[0]
            text = (
                f"{name}: {low.sum()} shapes have {what} faces (quality 4√3·area/Σedge² below {limit:g}; first: "
                f"shape {i}, quality {quality[i]:.2g}); "
            )
            if limit == REFUSE_QUALITY:
                raise ValueError(text + "cotan weights are undefined there. Drop or repair those shapes.")
            warn_user(text + "their cotan weights (∝ 1/quality) dominate the conformal operator.", MeshWarning)


def edge_face_counts(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undirected edges ``(e, 2)`` (sorted, ``i < j``) and the number of faces on each ``(e,)``."""
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0, return_counts=True)


def unique_edges(faces: np.ndarray) -> np.ndarray:
    """Undirected edges ``(e, 2)`` of a triangle list, each once, sorted ``i < j`` (found once per triangulation;
    each call returns its own copy).
    """
    return _memo.by_content("edges", (faces,), lambda: edge_face_counts(faces)[0]).copy()


def corner_edges(faces: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """The index into ``edges`` (:func:`unique_edges` of ``faces``) of the edge opposite each corner, ``(3m,)`` in
    corner order (face by face, corners 0, 1, 2): where each corner's cotangent goes.
    """
    opp = np.sort(np.stack([faces[:, [1, 2]], faces[:, [2, 0]], faces[:, [0, 1]]], axis=1).reshape(-1, 2), axis=1)
    n = int(faces.max()) + 1
    return np.searchsorted(edges[:, 0] * n + edges[:, 1], opp[:, 0] * n + opp[:, 1])


def _as_vertices(vertices) -> np.ndarray:
    """A float64 copy (the mesh freezes it) of checked ``(n, 3)`` coordinates, or a :class:`MeshError`."""
    try:
        v = real_array("vertices", vertices, ("n", 3), finite=False, hint="(xyz coordinates)").copy()
    except (TypeError, ValueError) as exc:
        raise MeshError(str(exc)) from None
    bad = ~np.isfinite(v).all(axis=1)
    if bad.any():
        raise MeshError(
            f"{bad.sum()} vertices have NaN or infinite coordinates (first: vertex {np.flatnonzero(bad)[0]}); "
            "remove or repair them before building the mesh."
        )
    return v


def as_faces(faces, n: int) -> np.ndarray:
    try:
        f = np.asarray(faces)
    except Exception:  # ragged lists, e.g. triangles mixed with quads
        raise MeshError("faces could not be read as an (m, 3) array; triangulate polygons first.") from None
    if f.ndim != 2 or f.shape[1] != 3:
        raise MeshError(
            f"faces have shape {f.shape}; pass an (m, 3) integer array of triangles (triangulate polygons first)."
        )
    if f.dtype.kind == "f":
        if not np.all(np.isfinite(f)) or np.any(f != np.round(f)):
            raise MeshError("faces hold non-integer values; faces are vertex indices, pass an integer array.")
    elif f.dtype.kind not in "iu":
        raise MeshError(f"faces have dtype {f.dtype}; pass an integer array of vertex indices.")
    f = f.astype(np.int64)
    if len(f) == 0:
        raise MeshError("the mesh has no faces; pass at least one triangle.")
    if f.min() < 0 or f.max() >= n:
        raise MeshError(
            f"face indices must lie in [0, {n - 1}] for {n} vertices, got range [{f.min()}, {f.max()}]; "
            "check for 1-based indices (subtract 1) or a faces array from another mesh."
        )
    return f


def _largest_component(v: np.ndarray, f: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices, re-indexed faces and kept vertex indices of the largest component (``labels`` per vertex)."""
    n = len(v)
    keep = labels == np.bincount(labels).argmax()
    kept = np.flatnonzero(keep)
    remap = np.full(n, -1)
    remap[kept] = np.arange(len(kept))
    f = remap[f[keep[f[:, 0]]]]
    return v[kept], f, kept


def components(faces: np.ndarray, n: int) -> tuple[int, np.ndarray]:
    """The connected components of a triangle list ``faces`` on ``n`` vertices: their number and each vertex's label
    ``(n,)`` (scipy's ``connected_components`` of the edge graph).
    """
    rows = faces[:, [0, 1, 2]].ravel()
    cols = faces[:, [1, 2, 0]].ravel()
    adj = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    return connected_components(adj, directed=False)


def _components_message(v: np.ndarray, f: np.ndarray, labels: np.ndarray, n_comp: int) -> str:
    sizes = np.sort(np.bincount(labels))[::-1]
    unused = len(v) - len(np.unique(f))
    detail = f" ({unused} of them are vertices used by no face)" if unused else ""
    text = (
        f"the mesh has {n_comp} connected components{detail}, sizes {sizes[:5].tolist()}{'...' if n_comp > 5 else ''}; "
        "the Laplacian of a disconnected mesh has several zero eigenvalues. "
    )
    repeats = len(v) - len(np.unique(v, axis=0))
    if repeats:
        return text + (
            f"{repeats} vertices repeat the position of another (a triangle soup, as STL files and some "
            "exporters write): merge them first, e.g. tm = trimesh.Trimesh(vertices, faces) (which merges "
            "them), then opnet.Mesh(tm.vertices, tm.faces)."
        )
    if sizes[0] < 4:
        return text + "No component has at least 4 vertices, as a surface needs: pass a connected triangle mesh."
    return text + "Pass keep_largest_component=True to keep the largest one."


class Mesh:
    """A validated triangle mesh.

    Parameters
    ----------
    vertices : array_like, (n, 3)
        Vertex coordinates (any length unit; stored as float64).
    faces : array_like, (m, 3)
        Triangles as vertex indices (stored as int64).
    keep_largest_component : bool
        If the mesh has several connected components (or unused vertices), keep the
        largest one instead of raising. ``mesh.kept_vertices`` maps the new vertex
        indices to the input's.
    normalize_area : bool
        Scale the mesh to unit total surface area about its area-weighted centroid
        (as the authors' code does before computing operators).

    Raises
    ------
    MeshError
        NaN/inf coordinates, wrong shapes or dtypes, face indices out of range,
        collapsed faces (quality ``4√3·area/Σedge²`` below ``1e-8``), non-manifold edges, several
        components, fewer than 4 vertices, a bounding-box diagonal outside ``[1e-40, 1e40]`` (unless
        ``normalize_area``).

    Warns
    -----
    MeshWarning
        Near-degenerate faces (quality below ``1e-4``), whose cotan weights dominate the conformal operator.
    """

    def __init__(self, vertices, faces, *, keep_largest_component: bool = False, normalize_area: bool = False):
        v = _as_vertices(vertices)
        if len(v) < 4:
            raise MeshError(
                f"the mesh has {len(v)} vertices; a closed or open surface needs at least 4 (a tetrahedron)."
            )
        f = as_faces(faces, len(v))
        kept = np.arange(len(v))
        n_comp, labels = components(f, len(v))
        if n_comp > 1:
            if not keep_largest_component:
                raise MeshError(_components_message(v, f, labels, n_comp))
            if np.bincount(labels).max() < 4:
                raise MeshError(_components_message(v, f, labels, n_comp))
            v, f, kept = _largest_component(v, f, labels)
        diagonal = float(span(v))
        if normalize_area and diagonal > 0:  # checked and normalised at unit size, so that any finite scale works
            v = v / diagonal
        elif _out_of_range(np.array(diagonal)):
            raise MeshError(
                f"the mesh spans {diagonal:.3g} length units (bounding-box diagonal), outside {list(SPAN_RANGE)}, "
                "where float64 areas and the extrinsic operator (∝ length⁶) under- or overflow; rescale the "
                "coordinates "
                f"(e.g. vertices / {diagonal:.3g}) or pass normalize_area=True."
            )
        self._check_faces(v, f)
        if normalize_area:
            a = face_areas(v, f)
            centroid = (a[:, None] * v[f].mean(axis=1)).sum(0) / a.sum()
            v = (v - centroid) / np.sqrt(a.sum())
        v.setflags(write=False)
        f.setflags(write=False)
        kept.setflags(write=False)
        self.vertices = v
        self.faces = f
        self.kept_vertices = kept

    @staticmethod
    def _check_faces(v: np.ndarray, f: np.ndarray) -> None:
        repeated = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0])
        if repeated.any():
            raise MeshError(
                f"{repeated.sum()} faces repeat a vertex (first: face {np.flatnonzero(repeated)[0]} = "
                f"{f[repeated][0].tolist()}); "
                "remove degenerate faces, e.g. trimesh's mesh.update_faces(mesh.nondegenerate_faces())."
            )
        quality = _quality(v, f)
        for limit in (REFUSE_QUALITY, WARN_QUALITY):
            low = np.flatnonzero(quality < limit)
            if len(low) == 0:
                continue
            worst = low[np.argsort(quality[low])][:5].tolist()
            others = f", then faces {worst[1:]}" if len(worst) > 1 else ""
            text = (
                f"{len(low)} faces have quality 4√3·area/Σedge² below {limit:g} (worst: face {worst[0]}, quality "
                f"{quality[worst[0]]:.2g}{others}; an equilateral triangle has 1)"
            )
            if limit == REFUSE_QUALITY:
                size, distance = float(span(v)), float(np.abs(v).max())
                cause = (
                    f" The shape spans {size:.2g} at {distance:.2g} from the origin: it is smaller than its distance "
                    "from the origin by more than float64 resolves; centre the coordinates where they are made."
                    if size < 1e-8 * distance
                    else ""
                )
                raise MeshError(
                    text + "; they have zero area or nearly, and cotan weights are undefined there. Remove "
                    "them or merge their collinear/duplicate vertices (trimesh: merge_vertices, "
                    "update_faces(nondegenerate_faces())). " + cause
                )
            warn_user(
                text + ": their cotan weights (∝ 1/quality) dominate the conformal operator. Remesh (e.g. "
                "isotropic remeshing in pymeshlab) or leave the conformal channel out.",
                MeshWarning,
            )
        _, counts = edge_face_counts(f)
        if (counts > 2).any():
            raise MeshError(
                f"{(counts > 2).sum()} edges are shared by more than two faces (non-manifold); the cotan Laplacian "
                "needs a manifold surface. Remove duplicate faces or repair the mesh (e.g. pymeshfix)."
            )

    # -- geometry ---------------------------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @cached_property
    def mass(self) -> np.ndarray:
        """Barycentric lumped mass ``A`` as a vector ``(n,)``: a third of each incident triangle's area."""
        mass = pp3d.vertex_areas(self.vertices, self.faces)
        mass.setflags(write=False)  # shared with every Eigenbasis of this mesh
        return mass

    @cached_property
    def stiffness(self) -> sp.csr_matrix:
        """Cotan stiffness ``W`` ``(n, n)``, positive semi-definite, rows summing to zero."""
        return pp3d.cotan_laplacian(self.vertices, self.faces).tocsr()

    @property
    def area(self) -> float:
        """Total surface area (squared length unit)."""
        return float(self.mass.sum())

    def with_vertices(self, vertices) -> "Mesh":
        """The same connectivity with new coordinates ``(n, 3)`` (validated)."""
        v = _as_vertices(vertices)
        if len(v) != self.n_vertices:
            raise MeshError(
                f"the coordinates are for {len(v)} vertices, this mesh has {self.n_vertices}: pass new "
                f"coordinates ({self.n_vertices}, 3) of the same vertices, or a Mesh of its own (and a map)."
            )
        return Mesh(v, self.faces)

    def __repr__(self) -> str:
        return f"Mesh(n_vertices={self.n_vertices}, n_faces={self.n_faces}, area={self.area:.4g})"


def load_mesh(path, **kwargs) -> Mesh:
    """Read a ``.ply``, ``.obj``, ``.off`` or ``.stl`` file into a validated :class:`~opnet.mesh.Mesh`.

    The vertex order of the file is kept (no merging or reordering), so meshes in
    correspondence stay in correspondence. STL stores every triangle with its own
    three vertices: those are merged, so an STL file cannot carry a vertex order.
    ``kwargs`` go to :class:`Mesh`.
    """
    import trimesh

    path = Path(path)
    if path.suffix.lower() not in _LOADABLE:
        raise MeshError(f"cannot read '{path.name}': supported formats are {', '.join(_LOADABLE)}.")
    if not path.is_file():
        raise FileNotFoundError(f"no mesh file at '{path}'.")
    try:
        tm = trimesh.load(path, force="mesh", process=False, maintain_order=True)
        if path.suffix.lower() == ".stl":
            tm.merge_vertices()
    except Exception as exc:
        raise MeshError(f"trimesh could not parse '{path}': {exc}") from exc
    if not hasattr(tm, "faces") or len(tm.faces) == 0:
        raise MeshError(f"'{path}' holds no triangles (a point cloud?); OperatorNet needs a triangle mesh.")
    return Mesh(tm.vertices, tm.faces, **kwargs)
