"""A rig on a template mesh: its body alone, closed and of genus 0, remeshed isotropically to about the paper's
1769 vertices (SMAL's simplified template), with the skin carried over by closest point.

The asset meshes are low-poly (about a thousand vertices), their triangles shaped by the modeller, and some come in
pieces: horns (bull, cow) and antlers (stag) are separate open shells, the alpaca has two stray two-face pieces.
The template keeps the largest piece, the body (the horns and antlers have no counterpart in the other species, and
the operators need one closed surface), which is closed in every asset but the stag's (a few edges on three or four
faces, two open ones), which MeshFix repairs. Remeshing (pymeshlab's
isotropic explicit remeshing, the MeshLab filter) gives triangles of nearly one size and shape, which the cotan
operators need; the skin weights of each template vertex are those of the closest point of the asset's body
(barycentric in its triangle), the four largest kept and normalised.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import cKDTree
from threadpoolctl import threadpool_limits

from ..._extras import require
from ..._files import silenced_fd2
from ...mesh import closest_points_on_faces, components, double_areas, edge_face_counts, face_edges
from .rig import Rig, largest_weights

__all__ = ["TEMPLATE_VERTICES", "body_template", "carried_skin"]

#: The paper's animal template (SMAL simplified): the vertex count the remeshing aims at.
TEMPLATE_VERTICES = 1769


def body_template(rig: Rig, n_vertices: int = TEMPLATE_VERTICES, iterations: int = 8) -> Rig:
    """``rig`` on a template of its body: closed, one piece, genus 0, about ``n_vertices`` vertices of nearly
    equilateral triangles (pymeshlab's isotropic remeshing, ``iterations`` passes), the skin carried over by closest
    point. Raises a ``ValueError`` when the body is not closed even after MeshFix's repair, or when the remeshing is
    not one closed genus-0 surface.
    """
    labels = components(rig.faces, len(rig.vertices))[1][rig.faces[:, 0]]
    areas = double_areas(face_edges(rig.vertices, rig.faces))
    body = labels == np.argmax(np.bincount(labels, weights=areas))
    faces = rig.faces[body]
    surface = rig.vertices, faces
    if not _closed(faces):  # the stag's body: a few edges on three or four faces, two open ones (MeshFix repairs it)
        meshfix = require("pymeshfix", "opnet.data.animals.body_template")
        with silenced_fd2():  # MeshFix may print "could not fix everything" to fd 2: the check below decides
            repaired = meshfix.clean_from_arrays(*surface)
        surface = np.asarray(repaired[0], dtype=np.float64), np.asarray(repaired[1], dtype=np.int64)
        if not _closed(surface[1]):
            raise ValueError(f"{rig.species}: the body (the largest piece of the mesh) is not closed, even repaired.")
    pymeshlab = require("pymeshlab", "opnet.data.animals.body_template")
    meshes = pymeshlab.MeshSet()
    meshes.add_mesh(pymeshlab.Mesh(*surface))
    # an equilateral triangle of side l has area √3/4 l², and a closed genus-0 mesh twice as many faces as vertices;
    # the remeshing's edges come out about 7 % shorter than its target (measured on the twelve animals)
    length = 1.07 * np.sqrt(areas[body].sum() / 2 / (np.sqrt(3) / 4 * 2 * n_vertices))
    # one OpenMP thread: with more, MeshLab's remeshing gives one of two meshes by the threads' timing (PyMeshLab
    # issue 323; here the horse's template had 1835 or 1836 vertices, and the registrations onto it differed)
    with threadpool_limits(limits=1, user_api="openmp"):
        meshes.meshing_isotropic_explicit_remeshing(targetlen=pymeshlab.PureValue(length), iterations=iterations)
    out = meshes.current_mesh()
    v, f = np.asarray(out.vertex_matrix(), dtype=np.float64), np.asarray(out.face_matrix(), dtype=np.int64)
    used = np.unique(f)
    v, f = v[used], np.searchsorted(used, f)
    euler = len(v) - len(edge_face_counts(f)[0]) + len(f)
    pieces = components(f, len(v))[0]
    if not _closed(f) or euler != 2 or pieces != 1:
        raise ValueError(
            f"{rig.species}: the remeshed body is not one closed genus-0 surface (closed: {_closed(f)}, {pieces} "
            f"piece(s), Euler characteristic {euler}); try body_template(rig, iterations={iterations + 4}) or "
            f"another n_vertices."
        )
    joints, weights = carried_skin(rig, v, faces)
    return dataclasses.replace(rig, vertices=v, faces=f, skin_joints=joints, skin_weights=weights)


def _closed(faces: np.ndarray) -> bool:
    """Every edge shared by exactly two faces."""
    return bool((edge_face_counts(faces)[1] == 2).all())


def carried_skin(rig: Rig, points: np.ndarray, faces: np.ndarray | None = None) -> tuple:
    """The skin of ``rig`` at ``points`` ``(p, 3)`` on its surface (``faces``, default all of the rig's): the four
    largest weights of the barycentric blend of the closest triangle's corners, normalised;
    ``(joints (p, 4), weights (p, 4))``.
    """
    faces = rig.faces if faces is None else faces
    on_body = np.unique(faces)
    near = on_body[cKDTree(rig.vertices[on_body]).query(points, k=min(8, len(on_body)))[1]]
    face, bary = closest_points_on_faces(points, rig.vertices, faces, near)
    return largest_weights(np.einsum("pc,pcj->pj", bary, rig.dense_skin()[faces[face]]))
