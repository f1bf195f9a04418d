"""A rigged animal: its mesh in the bind pose, its skin (joints and weights), its skeleton (a tree of nodes with
local rest transforms) and its animation clips; posed by forward kinematics and linear blend skinning (numpy,
float64).

Conventions are glTF's: a node's local transform is ``T · R · S`` (translation, rotation as a unit quaternion
``(x, y, z, w)``, scale), a joint's skinning matrix is its global transform times its inverse bind matrix, so the
bind pose (every joint at the inverse of its inverse bind matrix) gives back the mesh as stored, and clips
interpolate each channel linearly (rotations spherically).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

__all__ = ["Clip", "Rig", "largest_weights"]


@dataclass(frozen=True, eq=False)
class Clip:
    """An animation clip: ``channels`` maps ``(node, path)`` (``path`` one of ``"translation"``, ``"rotation"``,
    ``"scale"``) to ``(times (K,) s, values (K, 3 or 4), interpolation)`` with ``interpolation`` ``"LINEAR"`` or
    ``"STEP"``; ``duration`` is the last key time (s).
    """

    name: str
    duration: float
    channels: dict = field(repr=False)


@dataclass(frozen=True, eq=False)
class Rig:
    """A skinned, animated mesh (what :func:`opnet.data.animals.read_rig` returns).

    Attributes
    ----------
    species : the asset's name (``"horse"``).
    vertices : ``(n, 3)`` float64, metres: the bind pose (the mesh as stored, in metres).
    faces : ``(m, 3)`` int64.
    skin_joints, skin_weights : ``(n, 4)``: each vertex's joints (indices into ``joint_names``) and weights (sum 1).
    joint_names : ``(J,)`` the skin's joints; ``joint_nodes`` ``(J,)`` their nodes.
    inverse_bind : ``(J, 4, 4)`` float64, from metres (the bind pose) to each joint's frame.
    node_names : ``(N,)``; ``node_parents`` ``(N,)`` int, ``-1`` for a root; ``node_order`` parents before children.
    rest_translation, rest_rotation, rest_scale : ``(N, 3)``, ``(N, 4)`` ``(x, y, z, w)``, ``(N, 3)``: each node's
        local transform when no clip drives it. This rest pose is not the bind pose (the mesh as stored): the fox's
        joints sit up to 0.6 away from their bind transforms (in the skinning matrices' units), the horse's 0.01.
    clips : name → :class:`Clip`.
    """

    species: str
    vertices: np.ndarray
    faces: np.ndarray
    skin_joints: np.ndarray
    skin_weights: np.ndarray
    joint_names: tuple
    joint_nodes: np.ndarray
    inverse_bind: np.ndarray
    node_names: tuple
    node_parents: np.ndarray
    node_order: np.ndarray
    rest_translation: np.ndarray
    rest_rotation: np.ndarray
    rest_scale: np.ndarray
    clips: dict = field(repr=False)

    @property
    def clip_names(self) -> tuple:
        """The clips' names, sorted."""
        return tuple(sorted(self.clips))

    def dense_skin(self) -> np.ndarray:
        """The skin as a matrix ``(n, J)``: each vertex's weight on each joint."""
        dense = np.zeros((len(self.vertices), len(self.joint_names)))
        np.add.at(dense, (np.arange(len(self.vertices))[:, None], self.skin_joints), self.skin_weights)
        return dense

    def clip(self, name: str) -> Clip:
        """The clip ``name``; an unknown name raises a ``ValueError`` that lists the clips."""
        if name not in self.clips:
            raise ValueError(f"{self.species} has no clip {name!r}; its clips: {', '.join(self.clip_names)}.")
        return self.clips[name]

    def node_transforms(self, clip: str | None, times, turns=None) -> np.ndarray:
        """Every node's global transform ``(F, N, 4, 4)`` at ``times`` ``(F,)`` (s) of ``clip`` (``None``: the rest
        transforms, ``times`` then only sets ``F``). Times are clamped to ``[0, duration]``. ``turns`` ``(F, N, 3)``
        (rotation vectors, rad), if given, turn each node further about its own local axes, after the clip's rotation.
        """
        times = np.atleast_1d(np.asarray(times, dtype=np.float64))
        f, n = len(times), len(self.node_names)
        parts = {
            "translation": np.broadcast_to(self.rest_translation, (f, n, 3)).copy(),
            "rotation": np.broadcast_to(self.rest_rotation, (f, n, 4)).copy(),
            "scale": np.broadcast_to(self.rest_scale, (f, n, 3)).copy(),
        }
        if clip is not None:
            c = self.clip(clip)
            t = np.clip(times, 0.0, c.duration)
            for (node, path), (keys, values, interpolation) in c.channels.items():
                parts[path][:, node] = _sample(keys, values, t, interpolation, path == "rotation")
        if turns is not None:
            turned = Rotation.from_quat(parts["rotation"].reshape(-1, 4)) * Rotation.from_rotvec(
                np.asarray(turns, dtype=np.float64).reshape(-1, 3)
            )
            parts["rotation"] = turned.as_quat().reshape(f, n, 4)
        local = _compose(parts["translation"], parts["rotation"], parts["scale"])
        world = np.empty_like(local)
        for i in self.node_order:  # parents first
            p = self.node_parents[i]
            world[:, i] = local[:, i] if p < 0 else world[:, p] @ local[:, i]
        return world

    def skin(self, joint_transforms: np.ndarray) -> np.ndarray:
        """Linear blend skinning: vertices ``(F, n, 3)`` (m) for the joints' global transforms ``(F, J, 4, 4)``. The
        joints at the inverses of their inverse bind matrices give :attr:`vertices` back.
        """
        skinning = joint_transforms @ self.inverse_bind  # (F, J, 4, 4)
        blended = np.einsum("nk,fnkij->fnij", self.skin_weights, skinning[:, self.skin_joints, :3, :])
        return np.einsum("fnij,nj->fni", blended[..., :3], self.vertices) + blended[..., 3]

    def pose(self, clip: str, times, turns=None) -> np.ndarray:
        """The mesh ``(F, n, 3)`` (m) at ``times`` ``(F,)`` (s) of ``clip``, its nodes turned further by ``turns``
        ``(F, N, 3)`` if given (:meth:`node_transforms`).
        """
        return self.skin(self.node_transforms(clip, times, turns)[:, self.joint_nodes])

    def frames(self, clip: str, count: int) -> np.ndarray:
        """``count`` meshes ``(count, n, 3)`` (m) evenly spaced over ``clip``, its first and last key included."""
        return self.pose(clip, np.linspace(0.0, self.clip(clip).duration, count))


def largest_weights(dense: np.ndarray) -> tuple:
    """A skin ``(n, J)`` as four joints and weights per vertex ``(n, 4)``: the four largest, normalised to sum 1."""
    joints = np.argsort(-dense, axis=1)[:, :4]
    weights = np.take_along_axis(dense, joints, axis=1)
    return joints, weights / weights.sum(1, keepdims=True)


def _sample(keys, values, t, interpolation: str, rotation: bool) -> np.ndarray:
    """A channel's values at times ``t`` ``(F,)``: the keys' ``values`` ``(K, c)`` interpolated (rotations along the
    shorter arc: scipy's ``Slerp``), held at the first and the last key outside them (glTF's rule).
    """
    t = np.clip(t, keys[0], keys[-1])
    if interpolation == "STEP" or len(keys) == 1:
        return values[np.searchsorted(keys, t, side="right") - 1]
    if rotation:
        return Slerp(keys, Rotation.from_quat(values))(t).as_quat()
    return np.stack([np.interp(t, keys, column) for column in values.T], axis=-1)


def _compose(translation, rotation, scale) -> np.ndarray:
    """``T · R · S`` ``(..., 4, 4)`` from translations ``(..., 3)``, quaternions ``(..., 4)`` ``(x, y, z, w)`` (glTF's
    order, scipy's too) and scales ``(..., 3)``.
    """
    r = Rotation.from_quat(rotation.reshape(-1, 4)).as_matrix().reshape(*rotation.shape[:-1], 3, 3)
    out = np.zeros((*translation.shape[:-1], 4, 4))
    out[..., :3, :3] = r * scale[..., None, :]
    out[..., :3, 3] = translation
    out[..., 3, 3] = 1.0
    return out
