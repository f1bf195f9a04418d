"""One species' template laid onto another animal's body, so that every species shares one template's vertices.

Three steps, each a small numpy/scipy computation:

1. **Skeleton**: every template vertex moves with its joints from the source's bind skeleton to the target's (linear
   blend skinning with, for each joint, the transform from its bind frame in the source to its bind frame in the
   target; a joint the target lacks, an ear or tail segment, moves as its nearest ancestor that it has). The body
   lands roughly on the target: a few per cent of its height away.
2. **Surface**: a non-rigid ICP: each vertex is pulled to its closest point on the target's surface against the
   stiffness of a graph Laplacian, which keeps the template's local shape; the stiffness falls from rigid to
   loose in steps (:data:`STIFFNESS`).
3. **Relaxation**: a few tangential smoothing steps, each followed by a projection back onto the target's surface,
   even out the triangles that the fit stretched.

Measured from the horse's template onto six others (cow, wolf, alpaca, fox, stag, deer): 2-3 s each; the vertices
end on the target's surface (mean distance under 0.001 % of its height); after three relaxation steps the 1 %
quantile of face quality is 0.2-0.4 (0.05-0.15 without), but a few triangles stay thin (worst 0.002-0.09): what a
collection built on the registrations must check.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from scipy.spatial import cKDTree

from ...mesh import closest_points_on_faces, unique_edges
from ...spectral import vertex_normals
from .rig import Rig
from .template import carried_skin

__all__ = ["STIFFNESS", "register", "registered_rig", "surface_distance"]

#: The non-rigid ICP's Laplacian stiffness, one value per stage (four closest-point updates each).
STIFFNESS = (10.0, 3.0, 1.0, 0.3, 0.1)


def register(source: Rig, target: Rig, target_surface: Rig | None = None, relax: int = 3) -> np.ndarray:
    """The vertices ``(n, 3)`` (m) of ``source`` (a :func:`~opnet.data.animals.template.body_template`) laid onto
    ``target``'s body in its bind pose: moved with the skeleton, fitted to ``target_surface`` (default ``target``; a
    template of it is smoother) by non-rigid ICP, then relaxed ``relax`` times along the surface. The faces are
    ``source.faces``.
    """
    surface = target if target_surface is None else target_surface
    x = _along_the_skeleton(source, target)
    laplacian = _graph_laplacian(source.faces, len(x))
    tree = cKDTree(surface.vertices)
    for stiffness in STIFFNESS:
        system = sla.factorized(((stiffness**2) * (laplacian.T @ laplacian) + sp.identity(len(x))).tocsc())
        for _ in range(4):
            closest = _closest(x, surface, tree)
            rhs = (stiffness**2) * (laplacian.T @ (laplacian @ x)) + closest
            x = np.column_stack([system(rhs[:, i]) for i in range(3)])
    degree = np.asarray(abs(laplacian).sum(1)).ravel() / 2
    for _ in range(relax):
        step = -(laplacian @ x) / degree[:, None]  # to the neighbours' mean
        normal = vertex_normals(x, source.faces)
        step -= np.sum(step * normal, axis=1, keepdims=True) * normal  # along the surface only
        x = _closest(x + step, surface, tree)
    return x


def registered_rig(source: Rig, target: Rig, target_surface: Rig | None = None, relax: int = 3) -> Rig:
    """``target`` on ``source``'s template: the vertices of :func:`register`, ``source``'s faces, and ``target``'s
    skin carried over by closest point (:func:`~opnet.data.animals.template.carried_skin`), so that ``target``'s own
    clips pose it. Rigs registered from one source share its faces and vertex order: shapes in correspondence.
    """
    x = register(source, target, target_surface, relax)
    joints, weights = carried_skin(target, x)
    return dataclasses.replace(target, vertices=x, faces=source.faces, skin_joints=joints, skin_weights=weights)


def surface_distance(points: np.ndarray, surface: Rig) -> np.ndarray:
    """Each point's distance ``(p,)`` (m) to ``surface``'s mesh."""
    return np.linalg.norm(_closest(points, surface, cKDTree(surface.vertices)) - points, axis=1)


def _closest(points, surface: Rig, tree) -> np.ndarray:
    face, bary = closest_points_on_faces(points, surface.vertices, surface.faces, tree.query(points, k=8)[1])
    return np.einsum("pc,pci->pi", bary, surface.vertices[surface.faces[face]])


def _along_the_skeleton(source: Rig, target: Rig) -> np.ndarray:
    """``source``'s vertices skinned with, for each joint, its bind frame in ``target`` times the inverse of its
    bind frame in ``source`` (a joint the target lacks takes its nearest ancestor's).
    """
    frames_source, frames_target = np.linalg.inv(source.inverse_bind), np.linalg.inv(target.inverse_bind)
    in_target = {name: i for i, name in enumerate(target.joint_names)}
    joint_of_node = {node: j for j, node in enumerate(source.joint_nodes)}
    moves = np.empty_like(frames_source)
    for j, node in enumerate(source.joint_nodes):
        while source.node_names[node] not in in_target or node not in joint_of_node:
            node = source.node_parents[node]
            if node < 0:
                raise ValueError(
                    f"{source.species}'s joint {source.joint_names[j]!r} has no ancestor in {target.species}'s "
                    "skeleton: the two rigs share no skeleton to register along."
                )
        k = joint_of_node[node]
        moves[j] = frames_target[in_target[source.joint_names[k]]] @ np.linalg.inv(frames_source[k])
    blended = np.einsum("nk,nkij->nij", source.skin_weights, moves[source.skin_joints])
    return np.einsum("nij,nj->ni", blended[:, :3, :3], source.vertices) + blended[:, :3, 3]


def _graph_laplacian(faces: np.ndarray, n: int) -> sp.csr_matrix:
    """The uniform graph Laplacian ``D − A`` ``(n, n)`` of a mesh's edges."""
    e = unique_edges(faces)
    adjacency = sp.coo_matrix(
        (np.ones(2 * len(e)), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])), shape=(n, n)
    ).tocsr()
    return (sp.diags(np.asarray(adjacency.sum(1)).ravel()) - adjacency).tocsr()
