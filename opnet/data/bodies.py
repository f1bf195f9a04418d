"""Human bodies, heads and hands made offline with the parametric body model `anny`_.

They replace the paper's DFAUST/SURREAL humans (:func:`human_vertices`) and SMAL animals (the part
models: :func:`head_vertices`, :func:`hand_vertices`). All shapes of one model share their faces
and vertex order (1-1 correspondence); a shape is set by a *subject* (a phenotype vector,
:data:`PHENOTYPES`) and a *pose* or *expression*. Everything is numpy in and out; vertices are
float64 in metres. The same inputs give the same arrays (CPU float64 arithmetic; another
``batch_size`` changes them by round-off only, ~1e-16 m), and the random draws come from the
numpy generator passed in.

Coordinates (all models): ``+z`` up, ``+x`` the body's left, ``-y`` forward (the face and the
toes look along ``-y``). A human in the identity pose (:func:`rest_pose`) stands in anny's
A-pose with its root joint (the pelvis) at the origin, which stays there in every pose.

Body poses are anny's ``"local-ref"`` pose parameters, ``(bone_count, 4, 4)`` per shape: for each
bone a rotation about its joint, in axes that are the world axes of the rest pose carried along
by the bone's parent. They are built from named joint angles (:data:`JOINT_LIMITS`, in degrees,
clipped to anatomical limits, so knees and elbows never bend backwards): :func:`action_poses`
(:data:`ACTIONS`), :func:`random_poses`, or :func:`joint_poses` for any other.

Anny builds and caches its model data on first use (in ``$ANNY_CACHE_DIR``: seconds for most
models, about 1.5 minutes for the hand), and the models are kept in memory.

.. _anny: https://pypi.org/project/anny/
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "RESOLUTIONS",
    "PHENOTYPES",
    "AVERAGE_SUBJECT",
    "ACTIONS",
    "JOINT_LIMITS",
    "human_model",
    "human_faces",
    "human_vertices",
    "rest_pose",
    "joint_poses",
    "action_angles",
    "action_poses",
    "random_angles",
    "random_poses",
    "random_subjects",
    "FACIAL_ACTIONS",
    "HEAD_EXPRESSIONS",
    "head_model",
    "head_faces",
    "head_vertices",
    "expression_sequence",
    "random_expressions",
    "HAND_JOINT_LIMITS",
    "HAND_GESTURES",
    "hand_model",
    "hand_faces",
    "hand_vertices",
    "hand_poses",
    "gesture_sequence",
    "random_hand_poses",
]

# -- models ------------------------------------------------------------------------------------

#: Human topologies by approximate vertex count. "1k" is anny's own 1229-vertex mesh; anny ships
#: no finer simplification of its body (its "collapse5pc"/"collapse3pc" meshes have 615 and 369
#: vertices), so "2k" and "5k" are quadric decimations of anny's full 12272-vertex "notoes" mesh
#: to exactly 2000 and 5000 vertices, rigged by anny's own retopology (blendshapes and skinning
#: weights interpolated at the projection of each vertex onto the full mesh).
RESOLUTIONS = {"1k": "notoes_collapse10pc", "2k": "notoes_quadric2000", "5k": "notoes_quadric5000"}

#: Order of the columns of a subject vector; each value lies in [0, 1]. ``gender`` 0 is male and
#: 1 female; ``age`` is anny's age axis (0.67 ≈ 16 years, 0.77 ≈ 18, 0.83 ≈ 64, 1 ≈ 110).
PHENOTYPES = ("gender", "age", "muscle", "weight", "height", "proportions")

#: The base subject of the collections: an average adult of about 40 (anny age 0.8), 1.69 m tall.
#: (All-0.5 phenotypes would be an adolescent: anny's age 0.5 is about 13 years.)
AVERAGE_SUBJECT = (0.5, 0.8, 0.5, 0.5, 0.375, 0.5)

_QUADRIC_PREFIX = "notoes_quadric"


def _check_resolution(resolution: str) -> str:
    if resolution not in RESOLUTIONS:
        raise ValueError(f"resolution must be one of {list(RESOLUTIONS)}, got {resolution!r}.")
    return RESOLUTIONS[resolution]


def _decimated_notoes_model_data(n_vertices: int):
    """Anny model data on a quadric decimation of the "notoes" mesh to ``n_vertices`` vertices.

    Mirrors anny's ``build_alternative_topology_model_data`` (anny 0.6.2) with a decimated target
    mesh instead of a shipped one; the phenotype blendshapes are compacted as ``anny.Anny`` does.
    """
    import pyvista as pv
    import torch
    from anny.models.full_model import build_anny_model_data
    from anny.models.model_data import RigConfig, TopologyConfig, with_bone_orientation
    from anny.models.model_transforms import (
        apply_anny_cached_orientation,
        apply_retopology_from_mesh,
        compact_phenotype_blendshapes,
    )
    from anny.models.retopology import _load_target_topology_mesh
    from anny.utils.mesh_utils import triangulate_faces

    rig = RigConfig.from_string("anny")
    reference = build_anny_model_data(
        rig=with_bone_orientation(rig, "blender"),
        topology=TopologyConfig.from_string("anny"),
        local_changes="none",
        facial_actions="none",
    )
    vertices, quads = _load_target_topology_mesh("notoes")
    faces = np.asarray(triangulate_faces(vertices, quads), dtype=np.int64)
    full = pv.PolyData(vertices.numpy(), np.hstack([np.full((len(faces), 1), 3), faces]).ravel())
    # a closed triangle mesh with V vertices has 2V - 4 faces
    decimated = full.decimate(1 - (2 * n_vertices - 4) / len(faces), volume_preservation=True)
    target_faces = torch.tensor(decimated.faces.reshape(-1, 4)[:, 1:], dtype=torch.int64)
    data = apply_retopology_from_mesh(
        reference,
        target_vertices=torch.as_tensor(np.asarray(decimated.points), dtype=torch.float64),
        target_faces=target_faces,
        source_vertices=reference.template_vertices,
        source_faces=reference.faces,
        symmetry_axis=0,
    )
    data = apply_anny_cached_orientation(data)
    return compact_phenotype_blendshapes(data, phenotypes="default")


@functools.lru_cache(maxsize=None)
def human_model(resolution: str = "1k"):
    """The anny body model of a resolution (:data:`RESOLUTIONS`), float64, dense LBS skinning.

    The same rig (104 bones, :attr:`bone_labels`) for every resolution, so one pose array
    poses all of them alike. The decimated models' data is cached by anny next to its own.
    """
    import anny
    import torch
    from anny.models.model_data import cache_builder

    topology = _check_resolution(resolution)
    if topology.startswith(_QUADRIC_PREFIX):
        build = cache_builder(_decimated_notoes_model_data)
        model = anny.Anny.from_model_data(
            build(int(topology[len(_QUADRIC_PREFIX) :])),
            skinning_method="lbs",
            pose_parameterization="local-ref",
            bone_orientation="cached",
            root_identity_orientation=False,
        )
    else:
        model = anny.Anny(topology=topology, skinning_method="lbs")
    model = model.to(torch.float64).eval().requires_grad_(False)
    return model


def human_faces(resolution: str = "1k") -> np.ndarray:
    """Triangles ``(m, 3)`` int64 of a resolution's mesh (closed, one connected component)."""
    return human_model(resolution).faces.numpy().astype(np.int64)


def _check_subjects(subjects) -> np.ndarray:
    subjects = np.asarray(subjects, dtype=np.float64)
    if subjects.ndim != 2 or subjects.shape[1] != len(PHENOTYPES):
        raise ValueError(f"subjects must have shape (N, {len(PHENOTYPES)}), got {subjects.shape}.")
    return subjects


def _check_poses(poses, model, n: int) -> np.ndarray:
    poses = np.asarray(poses, dtype=np.float64)
    if poses.shape != (n, model.bone_count, 4, 4):
        raise ValueError(f"poses must have shape ({n}, {model.bone_count}, 4, 4), got {poses.shape}.")
    return poses


def _run_model(model, subjects: np.ndarray, n_vertices: int, batch_size: int, read, **inputs) -> np.ndarray:
    """Vertices ``(N, n_vertices, 3)`` from batches of anny calls on ``subjects`` ``(N, 6)``.

    ``read(result)`` turns each batch's result into vertices ``(b, n_vertices, 3)``; ``inputs`` are
    per-shape arrays ``(N, ...)`` passed to the model by keyword.
    """
    import torch
    from tqdm.auto import tqdm

    out = np.empty((len(subjects), n_vertices, 3))
    starts = range(0, len(subjects), batch_size)
    with torch.no_grad():
        for start in tqdm(starts, desc="meshes", unit="batch", disable=len(starts) < 8):
            batch = slice(start, start + batch_size)
            s = torch.from_numpy(subjects[batch])
            result = model(
                phenotype_kwargs={label: s[:, i] for i, label in enumerate(PHENOTYPES)},
                **{key: torch.from_numpy(value[batch]) for key, value in inputs.items()},
            )
            out[batch] = read(result).numpy()
    return out


def human_vertices(subjects, poses, resolution: str = "1k", batch_size: int = 256) -> np.ndarray:
    """Posed bodies: vertices ``(N, n, 3)`` float64 in metres.

    Parameters
    ----------
    subjects : (N, 6) array of phenotype values in [0, 1], columns in :data:`PHENOTYPES` order.
    poses : (N, bone_count, 4, 4) array of local-ref pose parameters (e.g. :func:`action_poses`).
    resolution : a key of :data:`RESOLUTIONS`.
    batch_size : shapes per anny call.
    """
    model = human_model(resolution)
    subjects = _check_subjects(subjects)
    poses = _check_poses(poses, model, len(subjects))
    return _run_model(
        model,
        subjects,
        len(model.template_vertices),
        batch_size,
        lambda result: result["vertices"],
        pose_parameters=poses,
    )


# -- joints and poses --------------------------------------------------------------------------

# Rest directions (average subject) of the left upper arm (shoulder -> elbow) and the hinge of the
# left elbow (cross product of the upper arm and forearm directions; the rest pose bends the
# elbow by 42 degrees and the knee by 9).
_LEFT_ARM = (0.6556, -0.0285, -0.7546)
_LEFT_ELBOW_HINGE = (-0.7546, -0.0626, -0.6532)
_SPINE = ("spine05", "spine04", "spine03", "spine02", "spine01")
_NECK = ("neck01", "neck02", "neck03", "head")

# Joint angles: name -> (bones sharing the angle equally, rotation axis of a positive angle,
# (min, max) in degrees). Central joints first, then the sided ones, given for the left side.
# Angles of one bone compose in table order (the first one outermost).
_CENTRAL_JOINTS = {
    "pelvis_flex": (("root",), (1, 0, 0), (-30, 30)),  # + tilts the whole body forward
    "pelvis_side": (("root",), (0, 1, 0), (-20, 20)),  # + tilts it to its left
    "pelvis_twist": (("root",), (0, 0, 1), (-45, 45)),  # + turns it to its left
    "spine_flex": (_SPINE, (1, 0, 0), (-25, 75)),  # + bends forward
    "spine_side": (_SPINE, (0, 1, 0), (-35, 35)),  # + bends to the left
    "spine_twist": (_SPINE, (0, 0, 1), (-45, 45)),  # + turns the chest to the left
    "neck_flex": (_NECK, (1, 0, 0), (-40, 50)),  # + looks down
    "neck_side": (_NECK, (0, 1, 0), (-35, 35)),  # + tilts the head to the left
    "neck_twist": (_NECK, (0, 0, 1), (-70, 70)),  # + turns the head to the left
}
_SIDED_JOINTS = {
    "clavicle_elevate": (("clavicle",), (0, -1, 0), (-10, 30)),  # + shrugs the shoulder
    "clavicle_protract": (("clavicle",), (0, 0, -1), (-20, 20)),  # + moves the shoulder forward
    "shoulder_flex": (("upperarm01",), (-1, 0, 0), (-45, 160)),  # + swings the arm forward and up
    "shoulder_abduct": (("upperarm01",), (0, -1, 0), (-30, 130)),  # + raises the arm sideways (0: A-pose)
    "shoulder_rotate": (("upperarm01",), tuple(-c for c in _LEFT_ARM), (-60, 60)),  # + turns the forearm outwards
    "elbow_flex": (("lowerarm01",), _LEFT_ELBOW_HINGE, (-38, 100)),  # + bends (0: rest's 42°, -38: straight)
    "hip_flex": (("upperleg01",), (-1, 0, 0), (-20, 120)),  # + swings the thigh forward
    "hip_abduct": (("upperleg01",), (0, -1, 0), (-15, 45)),  # + moves the leg sideways, outwards
    "hip_rotate": (("upperleg01",), (0, 0, 1), (-35, 45)),  # + turns the toes outwards
    "knee_flex": (("lowerleg01",), (1, 0, 0), (0, 130)),  # + bends (0: rest's 9°)
    "ankle_flex": (("foot",), (1, 0, 0), (-25, 45)),  # + points the toes down
}


def _all_joints() -> dict:
    """Every joint angle: the central ones and each sided one as ``name.L`` and ``name.R``.

    A right-side joint mirrors the left one through the ``x = 0`` plane: its axis is ``(a_x, -a_y, -a_z)``
    for the same angle, so equal angles on both sides give mirror-symmetric poses.
    """
    joints = dict(_CENTRAL_JOINTS)
    for side, mirror in (("L", (1, 1, 1)), ("R", (1, -1, -1))):
        for name, (bones, axis, limits) in _SIDED_JOINTS.items():
            joints[f"{name}.{side}"] = (tuple(f"{b}.{side}" for b in bones), tuple(np.multiply(axis, mirror)), limits)
    return joints


_JOINTS = _all_joints()

#: Anatomical limits ``(min, max)`` in degrees of every joint angle accepted by :func:`joint_poses`.
JOINT_LIMITS = {name: limits for name, (_, _, limits) in _JOINTS.items()}


def rest_pose() -> np.ndarray:
    """The identity pose ``(bone_count, 4, 4)``: anny's A-pose (arms 41° from the body, elbows bent 42°)."""
    return np.broadcast_to(np.eye(4), (human_model("1k").bone_count, 4, 4)).copy()


def _poses_from_angles(joints: dict, bone_labels, angles: dict, n: int | None) -> np.ndarray:
    """Pose parameters ``(n, len(bone_labels), 4, 4)`` from angles in degrees of the joints of a table
    ``{name: (bones, axis, (min, max))}`` (see :func:`joint_poses`).
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


def joint_poses(angles: dict, n: int | None = None) -> np.ndarray:
    """Body poses ``(n, bone_count, 4, 4)`` from joint angles in degrees.

    Parameters
    ----------
    angles : dict mapping names of :data:`JOINT_LIMITS` to scalars or arrays ``(n,)`` (degrees);
        missing joints stay at rest. Each angle is clipped to its anatomical limits.
    n : number of poses; defaults to the length of the arrays (1 for scalars).
    """
    return _poses_from_angles(_JOINTS, human_model("1k").bone_labels, angles, n)


# -- actions -----------------------------------------------------------------------------------


def _bump(t):
    """0 -> 1 -> 0 over one cycle, smoothly: ``(1 - cos 2πt) / 2``."""
    return 0.5 * (1 - np.cos(2 * np.pi * t))


def _pulse(t, center, width):
    """A Gaussian pulse of height 1 at phase ``center``."""
    return np.exp(-(((t - center) / width) ** 2))


def _both(name, left, right=None):
    """Angles of a sided joint: ``left`` for both sides unless ``right`` is given."""
    return {f"{name}.L": left, f"{name}.R": left if right is None else right}


def _walk(t):
    w = 2 * np.pi * t
    swing_l, swing_r = (0.5 * (1 + np.cos(w))) ** 3, (0.5 * (1 - np.cos(w))) ** 3
    return {
        **_both("hip_flex", 25 * np.sin(w), -25 * np.sin(w)),
        **_both("knee_flex", 5 + 55 * swing_l, 5 + 55 * swing_r),
        **_both("ankle_flex", -10 * swing_l, -10 * swing_r),
        **_both("shoulder_flex", -20 * np.sin(w), 20 * np.sin(w)),
        **_both("shoulder_abduct", -15),
        **_both("elbow_flex", 15),
        "spine_twist": -6 * np.sin(w),
    }


def _run_in_place(t):
    w = 2 * np.pi * t
    lift_l, lift_r = (0.5 * (1 + np.sin(w))) ** 3, (0.5 * (1 - np.sin(w))) ** 3
    return {
        **_both("hip_flex", 75 * lift_l, 75 * lift_r),
        **_both("knee_flex", 10 + 100 * lift_l, 10 + 100 * lift_r),
        **_both("ankle_flex", 20 * lift_l, 20 * lift_r),
        **_both("shoulder_flex", 35 * (lift_r - lift_l), 35 * (lift_l - lift_r)),
        **_both("shoulder_abduct", -10),
        **_both("elbow_flex", 55),
        "spine_flex": 5,
    }


def _arm_raise(t):
    b = _bump(t)
    return {**_both("shoulder_abduct", 115 * b), **_both("clavicle_elevate", 15 * b)}


def _knee_bend(t):
    b = _bump(t)
    return {
        **_both("hip_flex", 90 * b),
        **_both("knee_flex", 115 * b),
        **_both("ankle_flex", -20 * b),
        **_both("hip_abduct", 8 * b),
        **_both("shoulder_flex", 75 * b),
        **_both("elbow_flex", -25 * b),
        "spine_flex": 15 * b,
    }


def _jumping_jacks(t):
    b = _bump(t)
    return {
        **_both("shoulder_abduct", 120 * b),
        **_both("clavicle_elevate", 15 * b),
        **_both("elbow_flex", -20 * b),
        **_both("hip_abduct", 25 * b),
    }


def _punch(t):
    guard = _bump(t)
    right, left = _pulse(t, 0.35, 0.1), _pulse(t, 0.65, 0.1)
    return {
        **_both("shoulder_flex", guard * (45 + 40 * left), guard * (45 + 40 * right)),
        **_both("shoulder_abduct", -25 * guard),
        **_both("elbow_flex", guard * (85 - 120 * left), guard * (85 - 120 * right)),
        **_both("clavicle_protract", 15 * guard * left, 15 * guard * right),
        "spine_twist": 20 * guard * (right - left),
    }


def _torso_twist(t):
    s = np.sin(2 * np.pi * t)
    return {"spine_twist": 40 * s, "neck_twist": 15 * s, **_both("shoulder_abduct", 25), **_both("elbow_flex", 40)}


def _one_leg_balance(t):
    b = _bump(t)
    return {
        "hip_flex.L": 85 * b,
        "knee_flex.L": 95 * b,
        "ankle_flex.L": 20 * b,
        **_both("shoulder_abduct", 50 * b),
        "spine_side": -5 * b,
    }


def _shoulder_roll(t):
    w = 2 * np.pi * t
    return {**_both("clavicle_elevate", 12 * (1 - np.cos(w))), **_both("clavicle_protract", 15 * np.sin(w))}


def _hip_circle(t):
    w = 2 * np.pi * t
    flex, side = 20 * np.sin(w), 20 * np.cos(w)
    # the pelvis tilts around a circle while the chest and the legs stay upright
    return {
        "pelvis_flex": flex,
        "pelvis_side": side,
        "spine_flex": -flex,
        "spine_side": -side,
        **_both("hip_flex", flex),
        **_both("hip_abduct", side, -side),
    }


def _wave(t):
    g = _bump(t)
    return {"shoulder_abduct.R": 95 * g, "elbow_flex.R": 70 * g, "shoulder_rotate.R": 25 * g * np.sin(6 * np.pi * t)}


def _forward_bend(t):
    b = _bump(t)
    return {
        "spine_flex": 60 * b,
        "pelvis_flex": 25 * b,
        **_both("hip_flex", 25 * b),
        "neck_flex": -10 * b,
        **_both("shoulder_flex", 70 * b),
    }


def _side_bend(t):
    s = np.sin(2 * np.pi * t)
    return {
        "spine_side": 30 * s,
        "neck_side": 10 * s,
        **_both("shoulder_abduct", 100 * (0.5 * (1 - s)) ** 3, 100 * (0.5 * (1 + s)) ** 3),
    }


def _kick(t):
    g = _bump(t)
    extend = _pulse(t, 0.5, 0.12)
    return {
        "hip_flex.R": 80 * g,
        "knee_flex.R": g * (110 - 100 * extend),
        "ankle_flex.R": 30 * g,
        **_both("shoulder_abduct", -10 * g),
        **_both("elbow_flex", 60 * g),
        "spine_flex": -10 * g,
    }


_ACTIONS = {
    "walk": _walk,
    "run_in_place": _run_in_place,
    "arm_raise": _arm_raise,
    "knee_bend": _knee_bend,
    "jumping_jacks": _jumping_jacks,
    "punch": _punch,
    "torso_twist": _torso_twist,
    "one_leg_balance": _one_leg_balance,
    "shoulder_roll": _shoulder_roll,
    "hip_circle": _hip_circle,
    "wave": _wave,
    "forward_bend": _forward_bend,
    "side_bend": _side_bend,
    "kick": _kick,
}

#: Named motions for :func:`action_poses`; each is one smooth cycle of joint angles.
ACTIONS = tuple(_ACTIONS)


def _phases(n_frames: int, offset: float) -> np.ndarray:
    """Phases ``(k + offset) / n_frames`` of one cycle. An offset in (0, ½) avoids sampling a
    time-symmetric motion twice at the same pose (phases ``t`` and ``1 − t``).
    """
    return (np.arange(n_frames) + offset) / n_frames


def action_angles(action: str, n_frames: int, *, amplitude: float = 1.0, offset: float = 0.0) -> dict:
    """Joint angles in degrees ``{name: (n_frames,)}`` of an action (before clipping to the limits)."""
    if action not in _ACTIONS:
        raise ValueError(f"unknown action {action!r}; known: {ACTIONS}.")
    t = _phases(n_frames, offset)
    return {
        name: amplitude * np.broadcast_to(np.asarray(angle, dtype=np.float64), t.shape).copy()
        for name, angle in _ACTIONS[action](t).items()
    }


def action_poses(action: str, n_frames: int, *, amplitude: float = 1.0, offset: float = 0.0) -> np.ndarray:
    """Poses ``(n_frames, bone_count, 4, 4)`` of one cycle of an action, at phases ``(k + offset) / n_frames``.

    Every action is a smooth periodic motion; the one-shot ones (``arm_raise``, ``knee_bend``,
    ``one_leg_balance``, ``forward_bend``, ``jumping_jacks``, ``punch``, ``wave``, ``kick``) start
    at the rest pose and come back to it; the others (``walk``, ``run_in_place``, ``torso_twist``,
    ``shoulder_roll``, ``hip_circle``, ``side_bend``) are loops that may start mid-motion.
    ``amplitude`` scales every joint angle (1: the full motion); angles are clipped to
    :data:`JOINT_LIMITS`. The rig is the same at every resolution, so the poses are too.
    """
    return joint_poses(action_angles(action, n_frames, amplitude=amplitude, offset=offset), n_frames)


# -- random subjects and poses -----------------------------------------------------------------

# Sampling ranges (degrees) of random poses: moderate parts of the anatomical ranges, so that
# limbs stay clear of the body. The pelvis is not turned (random poses keep the root still).
_RANDOM_RANGES = {
    "spine_flex": (-15, 30),
    "spine_side": (-15, 15),
    "spine_twist": (-30, 30),
    "neck_flex": (-25, 35),
    "neck_side": (-20, 20),
    "neck_twist": (-45, 45),
    **{
        f"{name}.{side}": limits
        for side in "LR"
        for name, limits in {
            "clavicle_elevate": (-5, 20),
            "clavicle_protract": (-10, 15),
            "shoulder_flex": (-30, 70),
            "shoulder_abduct": (-10, 70),
            "shoulder_rotate": (-40, 40),
            "elbow_flex": (-35, 70),
            "hip_flex": (-15, 60),
            "hip_abduct": (-5, 30),
            "hip_rotate": (-20, 30),
            "knee_flex": (0, 100),
            "ankle_flex": (-15, 30),
        }.items()
    },
}


def random_angles(n: int, rng: np.random.Generator) -> dict:
    """Random joint angles in degrees ``{name: (n,)}``: each independent, Beta(2, 2)-distributed over its range."""
    return {name: lo + (hi - lo) * rng.beta(2.0, 2.0, n) for name, (lo, hi) in _RANDOM_RANGES.items()}


def random_poses(n: int, rng: np.random.Generator) -> np.ndarray:
    """Random poses ``(n, bone_count, 4, 4)`` (see :func:`random_angles`), within anatomical limits.

    The ranges keep limbs clear of the body: anny's self-intersection test finds a contact
    between parts (a hand grazing a thigh) in about 1 pose in 4000, fingers touching each other aside.
    """
    return joint_poses(random_angles(n, rng), n)


# Anny's age axis against age in years (anny's shape_calibration "morphological age" anchors).
_AGE_YEARS = (16.0, 18.0, 64.0, 110.0)
_AGE_ANNY = (0.67, 0.77, 0.83, 1.0)


def random_subjects(n: int, rng: np.random.Generator) -> np.ndarray:
    """Random adult subjects ``(n, 6)`` float64 in [0, 1], columns in :data:`PHENOTYPES` order.

    Gender uniform in [0, 1]; age uniform in 20-70 years; muscle and weight Beta(2, 2);
    height Beta(15, 25) (mean 0.375: about 1.76 m for men, 1.62 m for women, close to anny's
    calibration to WHO statistics); proportions uniform.
    """
    years = rng.uniform(20.0, 70.0, n)
    return np.stack(
        [
            rng.uniform(0.0, 1.0, n),
            np.interp(years, _AGE_YEARS, _AGE_ANNY),
            rng.beta(2.0, 2.0, n),
            rng.beta(2.0, 2.0, n),
            rng.beta(15.0, 25.0, n),
            rng.uniform(0.0, 1.0, n),
        ],
        axis=1,
    )


# -- heads -------------------------------------------------------------------------------------

#: Anny's 52 facial actions (ARKit blendshape names, as in ``anny.models.facial_actions``), the
#: columns of expression weights.
FACIAL_ACTIONS = (
    "browDownLeft",
    "browDownRight",
    "browInnerUp",
    "browOuterUpLeft",
    "browOuterUpRight",
    "cheekPuff",
    "cheekSquintLeft",
    "cheekSquintRight",
    "eyeBlinkLeft",
    "eyeBlinkRight",
    "eyeLookDownLeft",
    "eyeLookDownRight",
    "eyeLookInLeft",
    "eyeLookInRight",
    "eyeLookOutLeft",
    "eyeLookOutRight",
    "eyeLookUpLeft",
    "eyeLookUpRight",
    "eyeSquintLeft",
    "eyeSquintRight",
    "eyeWideLeft",
    "eyeWideRight",
    "jawForward",
    "jawLeft",
    "jawOpen",
    "jawRight",
    "mouthClose",
    "mouthDimpleLeft",
    "mouthDimpleRight",
    "mouthFrownLeft",
    "mouthFrownRight",
    "mouthFunnel",
    "mouthLeft",
    "mouthLowerDownLeft",
    "mouthLowerDownRight",
    "mouthPressLeft",
    "mouthPressRight",
    "mouthPucker",
    "mouthRight",
    "mouthRollLower",
    "mouthRollUpper",
    "mouthShrugLower",
    "mouthShrugUpper",
    "mouthSmileLeft",
    "mouthSmileRight",
    "mouthStretchLeft",
    "mouthStretchRight",
    "mouthUpperUpLeft",
    "mouthUpperUpRight",
    "noseSneerLeft",
    "noseSneerRight",
    "tongueOut",
)


def _symmetric(**weights) -> dict:
    """Facial action weights, ``name`` standing for ``nameLeft`` and ``nameRight`` when those exist."""
    out = {}
    for name, w in weights.items():
        pair = [f"{name}Left", f"{name}Right"]
        out.update(dict.fromkeys(pair if pair[0] in FACIAL_ACTIONS else [name], w))
    return out


#: Named facial expressions: weights in [0, 1] of :data:`FACIAL_ACTIONS` (the others are 0).
HEAD_EXPRESSIONS = {
    "smile": _symmetric(mouthSmile=1.0, cheekSquint=0.6, eyeSquint=0.3),
    "frown": _symmetric(mouthFrown=1.0, browInnerUp=0.7, mouthShrugLower=0.4),
    "surprise": _symmetric(browInnerUp=1.0, browOuterUp=1.0, eyeWide=1.0, jawOpen=0.5),
    "jaw_open": _symmetric(jawOpen=1.0),
    "pout": _symmetric(mouthPucker=1.0, mouthFunnel=0.3),
    "wink": {"eyeBlinkLeft": 1.0, "cheekSquintLeft": 0.6, "mouthSmileLeft": 0.5},
    "squint": _symmetric(eyeSquint=1.0, browDown=0.5),
    "disgust": _symmetric(noseSneer=1.0, mouthUpperUp=0.7, browDown=0.5),
    "anger": _symmetric(browDown=1.0, mouthPress=0.7, noseSneer=0.4, eyeSquint=0.4),
    "cheek_puff": _symmetric(cheekPuff=1.0, mouthClose=0.3),
    "blink": _symmetric(eyeBlink=1.0),
}


@functools.lru_cache(maxsize=None)
def head_model():
    """Anny's head model (``topology="head"``, rig ``"anny-head"``) with its 52 facial actions, float64."""
    import anny
    import torch

    model = anny.Anny(topology="head", rig="anny-head", facial_actions="all", skinning_method="lbs")
    return model.to(torch.float64).eval().requires_grad_(False)


@functools.lru_cache(maxsize=None)
def _head_component():
    """The head's largest connected component as ``(kept vertex indices, faces)``.

    Anny's head mesh has 4538 vertices in 4 components: the skin (with the mouth and eye cavities,
    open at the neck) and the separate eyeballs and tongue, which are dropped.
    """
    from ..mesh import Mesh

    model = head_model()
    mesh = Mesh(model.template_vertices.numpy(), model.faces.numpy(), keep_largest_component=True)
    return mesh.kept_vertices.copy(), mesh.faces


def head_faces() -> np.ndarray:
    """Triangles ``(8356, 3)`` int64 of the head skin: one component, open at the neck, with the mouth
    and eye cavities (the eyeballs and the tongue, separate components, are left out).
    """
    return _head_component()[1].astype(np.int64)


def _expression_vector(name: str) -> np.ndarray:
    if name not in HEAD_EXPRESSIONS:
        raise ValueError(f"unknown expression {name!r}; known: {tuple(HEAD_EXPRESSIONS)}.")
    weights = np.zeros(len(FACIAL_ACTIONS))
    for action, w in HEAD_EXPRESSIONS[name].items():
        weights[FACIAL_ACTIONS.index(action)] = w
    return weights


def expression_sequence(name: str, n_frames: int, *, amplitude: float = 1.0, offset: float = 0.0) -> np.ndarray:
    """Facial action weights ``(n_frames, n_actions)`` ramping smoothly 0 -> ``amplitude`` -> 0, at phases
    ``(k + offset) / n_frames``.
    """
    return amplitude * _bump(_phases(n_frames, offset))[:, None] * _expression_vector(name)[None, :]


def random_expressions(n: int, rng: np.random.Generator) -> np.ndarray:
    """Random facial action weights ``(n, n_actions)`` in [0, 1]: two named expressions of random
    intensities (uniform in [0, 1]) mixed, and the sum clipped to 1.
    """
    table = np.stack([_expression_vector(name) for name in HEAD_EXPRESSIONS])
    picks = rng.integers(0, len(table), (n, 2))
    intensity = rng.uniform(0.0, 1.0, (n, 2, 1))
    return np.clip((table[picks] * intensity).sum(axis=1), 0.0, 1.0)


def head_vertices(subjects, expression_weights, batch_size: int = 256) -> np.ndarray:
    """Heads: vertices ``(N, 4200, 3)`` float64 in metres, the neck joint at the origin, facing ``-y``.

    Only the skin is kept (see :func:`head_faces`): the largest component of anny's head mesh,
    the same vertex subset for every shape.

    Parameters
    ----------
    subjects : (N, 6) phenotype values (:data:`PHENOTYPES`).
    expression_weights : (N, n_actions) weights of :data:`FACIAL_ACTIONS` (e.g. :func:`expression_sequence`).
    """
    model = head_model()
    subjects = _check_subjects(subjects)
    weights = np.asarray(expression_weights, dtype=np.float64)
    if weights.shape != (len(subjects), len(FACIAL_ACTIONS)):
        raise ValueError(
            f"expression_weights must have shape ({len(subjects)}, {len(FACIAL_ACTIONS)}), got {weights.shape}."
        )
    kept = _head_component()[0]
    # the head is not posed: the facial actions are blendshapes of the rest mesh
    return _run_model(
        model,
        subjects,
        len(kept),
        batch_size,
        lambda result: result["rest_vertices"][:, kept] - result["rest_bone_heads"][:, :1],
        facial_actions=weights,
    )


# -- hands -------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=None)
def hand_model():
    """Anny's right hand (``topology="hand.R"``, rig ``"anny-hand.R"``: wrist and 20 finger bones), float64.

    Posed in anny's ``"local-bone"`` parameterization: each bone turns in its own axes, ``y`` along
    the bone and ``x`` the flexion hinge.
    """
    import anny
    import torch

    model = anny.Anny(topology="hand.R", rig="anny-hand.R", skinning_method="lbs", pose_parameterization="local-bone")
    return model.to(torch.float64).eval().requires_grad_(False)


def hand_faces() -> np.ndarray:
    """Triangles ``(3196, 3)`` int64 of the hand (1609 vertices, one component, open at the wrist)."""
    return hand_model().faces.numpy().astype(np.int64)


_FINGERS = {"index": "finger2", "middle": "finger3", "ring": "finger4", "pinky": "finger5"}

# Hand joint angles: name -> (bones, axis in the bone's own frame, (min, max) in degrees).
_HAND_JOINTS = {
    "thumb_cmc_flex": (("finger1-1.R",), (1, 0, 0), (-40, 45)),  # + moves the thumb across the palm
    "thumb_cmc_abduct": (("finger1-1.R",), (0, 0, -1), (-20, 40)),  # + lifts it away from the palm
    "thumb_mcp": (("finger1-2.R",), (1, 0, 0), (-10, 60)),  # + bends
    "thumb_ip": (("finger1-3.R",), (1, 0, 0), (-10, 80)),  # + bends
    **{
        name: joint
        for finger, bone in _FINGERS.items()
        for name, joint in {
            f"{finger}_mcp": ((f"{bone}-1.R",), (1, 0, 0), (-15, 90)),  # + bends towards the palm
            f"{finger}_spread": ((f"{bone}-1.R",), (0, 0, 1), (-25, 25)),  # + turns towards the little finger
            f"{finger}_pip": ((f"{bone}-2.R",), (1, 0, 0), (0, 105)),
            f"{finger}_dip": ((f"{bone}-3.R",), (1, 0, 0), (0, 80)),
        }.items()
    },
}

#: Anatomical limits ``(min, max)`` in degrees of the hand joint angles.
HAND_JOINT_LIMITS = {name: limits for name, (_, _, limits) in _HAND_JOINTS.items()}


# Per-finger spread that keeps curled fingers side by side (they converge as they bend).
_CURL_SPREAD = {"index": -4.0, "middle": 0.0, "ring": 4.0, "pinky": 8.0}


def _curl(finger: str, amount):
    """Angles bending a finger by ``amount`` (0: straight, 1: into a fist, fingertips on the palm)."""
    return {
        f"{finger}_mcp": 75 * amount,
        f"{finger}_pip": 90 * amount,
        f"{finger}_dip": 55 * amount,
        f"{finger}_spread": _CURL_SPREAD[finger] * amount,
    }


def _fist_except(*straight: str) -> dict:
    return {k: v for finger in _FINGERS if finger not in straight for k, v in _curl(finger, 1.0).items()}


_SPREAD = {"index_spread": -12, "ring_spread": 8, "pinky_spread": 16}
_THUMB_ACROSS = {"thumb_cmc_flex": 35, "thumb_cmc_abduct": 15, "thumb_mcp": 35, "thumb_ip": 35}
_THUMB_OUT = {"thumb_cmc_flex": -25, "thumb_cmc_abduct": 10}

#: Named hand gestures: hand joint angles in degrees (:data:`HAND_JOINT_LIMITS`; the others are 0).
HAND_GESTURES = {
    "open": {**_SPREAD, **_THUMB_OUT},
    "fist": {**_fist_except(), **_THUMB_ACROSS},
    "point": {**_fist_except("index"), **_THUMB_ACROSS},
    "pinch": {
        "index_mcp": 45,
        "index_pip": 45,
        "index_dip": 20,
        "thumb_cmc_flex": 35,
        "thumb_cmc_abduct": 10,
        "thumb_mcp": 20,
        "thumb_ip": 15,
        **_curl("middle", 0.3),
        **_curl("ring", 0.35),
        **_curl("pinky", 0.4),
    },
    "thumbs_up": {**_fist_except(), **_THUMB_OUT},
    "peace": {**_fist_except("index", "middle"), **_THUMB_ACROSS, "index_spread": -10, "middle_spread": 8},
    "ok": {
        "index_mcp": 50,
        "index_pip": 60,
        "index_dip": 35,
        "thumb_cmc_flex": 25,
        "thumb_cmc_abduct": 5,
        "thumb_mcp": 10,
        "thumb_ip": 15,
        "ring_spread": 8,
        "pinky_spread": 16,
    },
    "claw": {
        **{f"{f}_{j}": a for f in _FINGERS for j, a in (("mcp", 15), ("pip", 80), ("dip", 60))},
        **_SPREAD,
        "thumb_cmc_flex": 10,
        "thumb_mcp": 30,
        "thumb_ip": 45,
    },
    "rock": {**_fist_except("index", "pinky"), **_THUMB_ACROSS, "pinky_spread": 10},
    "call_me": {**_fist_except("pinky"), **_THUMB_OUT, "pinky_spread": 16},
}


def hand_poses(angles: dict, n: int | None = None) -> np.ndarray:
    """Hand poses ``(n, 21, 4, 4)`` from hand joint angles in degrees (see :func:`joint_poses`)."""
    return _poses_from_angles(_HAND_JOINTS, hand_model().bone_labels, angles, n)


def gesture_sequence(name: str, n_frames: int, *, amplitude: float = 1.0, offset: float = 0.0) -> np.ndarray:
    """Hand poses ``(n_frames, 21, 4, 4)`` closing smoothly from rest into a gesture (its joint angles
    scaled by ``amplitude``) and back, at phases ``(k + offset) / n_frames``.
    """
    if name not in HAND_GESTURES:
        raise ValueError(f"unknown gesture {name!r}; known: {tuple(HAND_GESTURES)}.")
    ramp = amplitude * _bump(_phases(n_frames, offset))
    return hand_poses({joint: ramp * angle for joint, angle in HAND_GESTURES[name].items()}, n_frames)


def random_hand_poses(n: int, rng: np.random.Generator) -> np.ndarray:
    """Random hand poses ``(n, 21, 4, 4)``: a hand-wide curl in [0, 1] varied per finger, the
    distal joints following the middle ones, a random spread and a random thumb.
    """
    curl = np.clip(rng.uniform(0.0, 1.0, (n, 1)) + rng.normal(0.0, 0.15, (n, len(_FINGERS))), 0.0, 1.0)
    angles = {}
    for i, finger in enumerate(_FINGERS):
        angles.update(_curl(finger, curl[:, i]))
        angles[f"{finger}_mcp"] = angles[f"{finger}_mcp"] * rng.uniform(0.8, 1.1, n)
        open_spread = (1 - curl[:, i]) * _SPREAD.get(f"{finger}_spread", 0)
        angles[f"{finger}_spread"] = angles[f"{finger}_spread"] + open_spread + rng.uniform(-2, 2, n)
    angles["thumb_cmc_flex"] = rng.uniform(-25, 35, n)
    # a thumb moved across the palm must also lift off it, to pass over the index finger
    angles["thumb_cmc_abduct"] = 0.5 * np.clip(angles["thumb_cmc_flex"], 0, None) + rng.uniform(0, 15, n)
    angles["thumb_mcp"] = rng.uniform(0, 40, n)
    angles["thumb_ip"] = rng.uniform(0, 50, n)
    return hand_poses(angles, n)


def hand_vertices(subjects, poses, batch_size: int = 256) -> np.ndarray:
    """Right hands: vertices ``(N, n, 3)`` float64 in metres, the wrist joint at the origin.

    The hand is oriented as on the body in the rest pose (hanging by the thigh, fingers down and
    forward). ``poses`` ``(N, 21, 4, 4)`` are local-bone parameters (e.g. :func:`gesture_sequence`);
    the wrist (root) bone is kept at its rest pose.
    """
    import torch

    model = hand_model()
    subjects = _check_subjects(subjects)
    poses = _check_poses(poses, model, len(subjects)).copy()
    poses[:, 0] = np.eye(4)

    def read(result):
        # with an identity root delta anny puts the root bone at the origin with identity axes;
        # turning by the rest root orientation brings the hand back to its rest orientation
        return torch.einsum("bij,bnj->bni", result["rest_bone_poses"][:, 0, :3, :3], result["vertices"])

    return _run_model(model, subjects, len(model.template_vertices), batch_size, read, pose_parameters=poses)
