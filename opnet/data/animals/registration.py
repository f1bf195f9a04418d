"""One species' template laid onto another animal's body, so that every species shares one template's vertices.

Three steps, each a small numpy/scipy computation:

1. **Skeleton**: every template vertex moves with its joints from the source's bind skeleton to the target's (linear
   blend skinning with, for each joint, the transform from its bind frame in the source to its bind frame in the
   target; a joint the target lacks, an ear or tail segment, moves as its nearest ancestor that it has). The body
   lands roughly on the target: a few per cent of its height away.
2. **Surface**: a non-rigid ICP: each iteration steps the vertices towards their closest points on the target's
   surface, the step smoothed by a graph Laplacian whose weight (:data:`STIFFNESS`) falls in five stages (the
   energy: :func:`register`). The first :data:`PARTWISE_STAGES` seek closest points on the same body part (a tail
   cannot end on a leg), the last ones anywhere (so that the body parts' borders close up).
3. **Relaxation**: :data:`RELAX` tangential smoothing steps, each followed by a projection back onto the target's
   surface, even out the triangles that the fit stretched.

Measured from the horse's template onto the ten other species in their rest pose (2026-12-03): about a minute for
all ten on 2 cores; worst triangle quality 0.0013 (bull), 0.0014 (stag), 0.012-0.071 (alpaca, cow, deer, donkey,
husky, wolf), 0.17-0.51 (shiba inu, fox); sharp folds (dihedral cosine below -0.9) 44 on the bull, 24 on the wolf
(the wolf's own template has 24), 11 on the husky. Tried and not kept: an anchoring term towards the skeleton's
pose, stiff-only fits (more folds), scaling bones by length ratios in the skeleton step (no gain), a local
projected smoothing of the worst triangles (worse on the donkey). The collection refuses the posed shapes whose
worst triangle is below its threshold (:data:`opnet.data.animals.collection.MIN_QUALITY`).
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

__all__ = ["PARTWISE_STAGES", "RELAX", "STIFFNESS", "body_part", "register", "registered_rig", "surface_distance"]

#: The non-rigid ICP's Laplacian stiffness, one value per stage (four closest-point updates each).
STIFFNESS = (10.0, 3.0, 1.0, 0.3, 0.1)
#: How many of the first stages seek closest points on the same body part only.
PARTWISE_STAGES = 3
#: Tangential relaxation steps after the fit (each projected back onto the surface).
RELAX = 25


def register(source: Rig, target: Rig, target_surface: Rig | None = None, relax: int = RELAX) -> np.ndarray:
    """The vertices ``(n, 3)`` (m) of ``source`` (a :func:`~opnet.data.animals.template.body_template`) laid onto
    ``target``'s body in its bind pose: moved with the skeleton, fitted to ``target_surface`` (default
    ``body_template(target)``: the body alone, without horns or antlers) by non-rigid ICP, then relaxed ``relax``
    times along the surface. The faces are ``source.faces``.

    Each ICP iteration solves ``s² ‖L (x − x_prev)‖² + ‖x − c‖²`` for the vertices ``x`` (``L`` the template's graph
    Laplacian, ``s`` the stage's :data:`STIFFNESS`, ``c`` the closest points to ``x_prev``): a step towards the
    closest points, smoothed by the Laplacian, the stronger the stiffer. In the first :data:`PARTWISE_STAGES` stages
    closest points are sought on the same body part (:func:`body_part` of each vertex's main joint): a tail longer
    than the target's cannot end on a leg; then anywhere on the surface.
    """
    from .template import body_template

    surface = body_template(target) if target_surface is None else target_surface
    x = _along_the_skeleton(source, target)
    laplacian = _graph_laplacian(source.faces, len(x))
    partwise, anywhere = _Closest(source, surface), _Closest(source, surface, by_part=False)
    for stage, stiffness in enumerate(STIFFNESS):
        closest = partwise if stage < PARTWISE_STAGES else anywhere
        system = sla.factorized(((stiffness**2) * (laplacian.T @ laplacian) + sp.identity(len(x))).tocsc())
        for _ in range(4):
            rhs = (stiffness**2) * (laplacian.T @ (laplacian @ x)) + closest(x)
            x = np.column_stack([system(rhs[:, i]) for i in range(3)])
    degree = np.asarray(abs(laplacian).sum(1)).ravel() / 2
    for _ in range(relax):
        step = -(laplacian @ x) / degree[:, None]  # to the neighbours' mean
        normal = vertex_normals(x, source.faces)
        step -= np.sum(step * normal, axis=1, keepdims=True) * normal  # along the surface only
        x = anywhere(x + step)
    return x


def body_part(joint: str) -> str:
    """The coarse part a joint belongs to: ``"tail"``, ``"front.L"``, ``"front.R"``, ``"back.L"``, ``"back.R"``
    (a leg, its shoulder, hoof or paw) or ``"body"`` (trunk, neck, head, ears).
    """
    stem, _, side = joint.partition(".")
    if stem.startswith("Tail"):
        return "tail"
    if stem in ("FFB", "IKBackLeg") or (stem.startswith("Back") and ("Leg" in stem or "Shoulder" in stem)):
        return f"back.{side}"
    if stem in ("FF", "IKFrontLeg") or (stem.startswith("Front") and ("Leg" in stem or "Shoulder" in stem)):
        return f"front.{side}"
    return "body"


class _Closest:
    """Closest points on ``surface`` for points of ``source``'s template, each sought on its own body part
    (``by_part``) or anywhere.
    """

    def __init__(self, source: Rig, surface: Rig, by_part: bool = True):
        mine = _parts(source) if by_part else np.zeros(len(source.vertices), dtype=int)
        theirs = _parts(surface) if by_part else np.zeros(len(surface.vertices), dtype=int)
        face_part = theirs[surface.faces[:, 0]]
        self.surface = surface
        self.groups = []
        for part in np.unique(mine):
            faces = surface.faces[face_part == part] if (face_part == part).any() else surface.faces
            used = np.unique(faces)
            self.groups.append((np.flatnonzero(mine == part), faces, used, cKDTree(surface.vertices[used])))

    def __call__(self, points: np.ndarray) -> np.ndarray:
        out = np.empty_like(points)
        v = self.surface.vertices
        for rows, faces, used, tree in self.groups:
            near = used[tree.query(points[rows], k=min(8, len(used)))[1]]
            face, bary = closest_points_on_faces(points[rows], v, faces, near)
            out[rows] = np.einsum("pc,pci->pi", bary, v[faces[face]])
        return out


def _parts(rig: Rig) -> np.ndarray:
    """Each vertex's :func:`body_part`, from its largest skin weight."""
    main = rig.skin_joints[np.arange(len(rig.vertices)), rig.skin_weights.argmax(1)]
    return np.array([body_part(rig.joint_names[j]) for j in main])


def registered_rig(source: Rig, target: Rig, target_surface: Rig | None = None, relax: int = RELAX) -> Rig:
    """``target`` on ``source``'s template: the vertices of :func:`register`, ``source``'s faces, and ``target``'s
    skin carried over by closest point (:func:`~opnet.data.animals.template.carried_skin`), so that ``target``'s own
    clips pose it. Rigs registered from one source share its faces and vertex order: shapes in correspondence.
    """
    x = register(source, target, target_surface, relax)
    joints, weights = carried_skin(target, x)
    return dataclasses.replace(target, vertices=x, faces=source.faces, skin_joints=joints, skin_weights=weights)


def surface_distance(points: np.ndarray, surface: Rig) -> np.ndarray:
    """Each point's distance ``(p,)`` (m) to ``surface``'s mesh (among the faces around its 8 nearest vertices: an
    upper bound, exact where the surface is not folded close to the point).
    """
    near = cKDTree(surface.vertices).query(points, k=8)[1]
    face, bary = closest_points_on_faces(points, surface.vertices, surface.faces, near)
    return np.linalg.norm(np.einsum("pc,pci->pi", bary, surface.vertices[surface.faces[face]]) - points, axis=1)


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
                    "skeleton: the two rigs share no skeleton to register along; register between rigs of the "
                    "asset package (they share one armature)."
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
