"""What the motions of humans and hands share: smooth timing over one cycle, and pose matrices from named
joint angles (numpy only; the rigs' bone names come from :mod:`opnet.data.anny_adapter`).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["bump", "phases", "poses_from_angles", "check_poses"]


def bump(t):
    """0 -> 1 -> 0 over one cycle, smoothly: ``(1 - cos 2πt) / 2``."""
    return 0.5 * (1 - np.cos(2 * np.pi * t))


def phases(n_frames: int, offset: float) -> np.ndarray:
    """Phases ``(k + offset) / n_frames`` of one cycle. An offset in (0, ½) avoids sampling a
    time-symmetric motion twice at the same pose (phases ``t`` and ``1 − t``).
    """
    return (np.arange(n_frames) + offset) / n_frames


def poses_from_angles(joints: dict, bone_labels, angles: dict, n: int | None) -> np.ndarray:
    """Pose parameters ``(n, len(bone_labels), 4, 4)`` from angles in degrees of the joints of a table
    ``{name: (bones, axis, (min, max))}`` (see :func:`opnet.data.humans.joint_poses`).
    """
    unknown = set(angles) - set(joints)
    if unknown:
        raise ValueError(f"unknown joint angles {sorted(unknown)}; known: {sorted(joints)}.")
    values = {k: np.atleast_1d(np.asarray(v, dtype=np.float64)) for k, v in angles.items()}
    if n is None:
        n = max((len(v) for v in values.values()), default=1)
    poses = np.broadcast_to(np.eye(4), (n, len(bone_labels), 4, 4)).copy()
    rotations = {}
    for name, (bones, axis, (lo, hi)) in joints.items():
        if name not in values:
            continue
        angle = np.radians(np.clip(np.broadcast_to(values[name], (n,)), lo, hi)) / len(bones)
        rotation = Rotation.from_rotvec(angle[:, None] * np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis))
        for bone in bones:
            rotations[bone] = rotations[bone] * rotation if bone in rotations else rotation
    for bone, rotation in rotations.items():
        poses[:, list(bone_labels).index(bone), :3, :3] = rotation.as_matrix().reshape(n, 3, 3)
    return poses


def check_poses(poses, bone_count: int, n: int) -> np.ndarray:
    """``poses`` as a float64 array ``(n, bone_count, 4, 4)``, or a ValueError naming the expected shape."""
    poses = np.asarray(poses, dtype=np.float64)
    if poses.shape != (n, bone_count, 4, 4):
        raise ValueError(f"poses must have shape ({n}, {bone_count}, 4, 4), got {poses.shape}.")
    return poses
