"""Assemble a :class:`~opnet.data.storage.Collection` from shapes in correspondence: the base eigenbasis, the
operators (fast path) and the evaluation subset. Used by the named generators and by :func:`opnet.data.load_folder`.
"""

from __future__ import annotations

import numpy as np

from .._checks import real_array
from .._deprecation import renamed_keyword
from .._parallel import cluster_backend
from ..inner_products import INNER_PRODUCTS, channel_digest, get_inner_products
from ..mesh import Mesh, check_shapes
from ..shape_difference import KINDS, shape_differences
from ..spectral import eigenbasis
from .channels import chunked_operators, warn_if_not_rigid
from .splits import furthest_point_subset
from .storage import Collection

__all__ = ["assemble"]


@renamed_keyword("kinds", "channels")
def assemble(
    vertices: np.ndarray,
    faces: np.ndarray,
    base_vertices: np.ndarray,
    split: np.ndarray,
    subcollection: np.ndarray,
    subject: np.ndarray,
    params: dict,
    meta: dict,
    *,
    k: int = 60,
    progress: bool | None = None,
    n_eval: int = 5,
    fps_vertices: np.ndarray | None = None,
    channels=KINDS,
) -> Collection:
    """A :class:`Collection` from shapes in correspondence: computes the base eigenbasis, the operators
    (fast path) and the evaluation subset (``n_eval`` shapes per test sub-collection by furthest-point
    sampling on Hausdorff distance: 10 × 5 = 50 as in the paper, fewer when a sequence is shorter).
    ``fps_vertices`` (N, n', 3), default ``vertices``, are the shapes the subset is chosen on. ``channels``: the
    channels computed (default the paper's three), in that order.
    """
    ips = get_inner_products(channels)
    base = Mesh(base_vertices, faces)
    basis = eigenbasis(base, k)
    for ip in ips:
        if ip.name not in INNER_PRODUCTS:
            warn_if_not_rigid(ip, basis)
    if cluster_backend() is None:
        operators = shape_differences(basis, vertices, ips, progress=progress).astype(np.float32)
    else:  # checked here, then computed in chunks on the cluster's workers
        check_shapes("vertices", real_array("vertices", vertices, ("B", base.n_vertices, 3)), faces)
        operators = chunked_operators(basis, vertices, ips, progress=progress)
    subset = []
    fps_vertices = vertices if fps_vertices is None else fps_vertices
    for sc in sorted(set(subcollection[split == "test"])):
        members = np.flatnonzero((subcollection == sc) & (split == "test"))
        subset.extend(members[furthest_point_subset(fps_vertices[members], n_eval)])
    coll = Collection(
        vertices.astype(np.float32),
        faces,
        operators,
        split,
        subcollection,
        subject,
        basis,
        np.array(sorted(subset), dtype=np.int64),
        params,
        dict(meta, k=k),
        tuple(ip.name for ip in ips),
        {ip.name: channel_digest(ip) for ip in ips},
    )
    coll._instances.update({ip.name: ip for ip in ips})
    return coll
