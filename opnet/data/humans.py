"""Human bodies in motion, made offline with the parametric body model anny.

They replace the paper's DFAUST/SURREAL humans. All bodies share their faces and vertex order (1-1
correspondence); a body is set by a *subject* (a phenotype vector, :mod:`opnet.data.subjects`) and a *pose*.
Everything is numpy in and out; vertices are float64 in metres. The same inputs give the same arrays (CPU
float64 arithmetic; another ``batch_size`` changes them by round-off only, ~1e-16 m), and the random draws come
from the numpy generator passed in.

Coordinates (all models): ``+z`` up, ``+x`` the body's left, ``-y`` forward (the face and the
toes look along ``-y``). A human in the identity pose (:func:`rest_pose`) stands in anny's
A-pose with its root joint (the pelvis) at the origin, which stays there in every pose.

Body poses are anny's ``"local-ref"`` pose parameters, ``(bone_count, 4, 4)`` per shape: for each
bone a rotation about its joint, in axes that are the world axes of the rest pose carried along
by the bone's parent. They are built from named joint angles (:data:`JOINT_LIMITS`, in degrees,
clipped to anatomical limits, so knees and elbows never bend backwards): :func:`action_poses`
(:data:`ACTIONS`), :func:`random_poses`, or :func:`joint_poses` for any other.
"""

from __future__ import annotations

import numpy as np

from .motion import bump, check_poses, phases, poses_from_angles
from .subjects import check_subjects

__all__ = [
    "RESOLUTIONS",
    "ACTIONS",
    "JOINT_LIMITS",
    "human_faces",
    "human_vertices",
    "rest_pose",
    "joint_poses",
    "action_angles",
    "action_poses",
    "random_angles",
    "random_poses",
]

#: Human resolutions by approximate vertex count: ``"1k"`` (1229 vertices, anny's own mesh), ``"2k"`` and ``"5k"``
#: (decimations of anny's full mesh; see :data:`opnet.data.anny_adapter.RESOLUTIONS`).
RESOLUTIONS = ("1k", "2k", "5k")


def _model(resolution: str = "1k"):
    from .anny_adapter import human_model

    return human_model(resolution)


def human_faces(resolution: str = "1k") -> np.ndarray:
    """Triangles ``(m, 3)`` int64 of a resolution's mesh (closed, one connected component)."""
    from .anny_adapter import faces

    return faces(_model(resolution))


def human_vertices(subjects, poses, resolution: str = "1k", batch_size: int = 256) -> np.ndarray:
    """Posed bodies: vertices ``(N, n, 3)`` float64 in metres.

    Parameters
    ----------
    subjects : (N, 6) array of phenotype values in [0, 1], columns in :data:`~opnet.data.subjects.PHENOTYPES` order.
    poses : (N, bone_count, 4, 4) array of local-ref pose parameters (e.g. :func:`action_poses`).
    resolution : one of :data:`RESOLUTIONS`.
    batch_size : shapes per anny call.
    """
    from .anny_adapter import bone_labels, evaluate

    model = _model(resolution)
    subjects = check_subjects(subjects)
    poses = check_poses(poses, len(bone_labels(model)), len(subjects))
    return evaluate(model, subjects, read="posed", batch_size=batch_size, pose_parameters=poses)


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


def _bone_labels() -> tuple[str, ...]:
    from .anny_adapter import bone_labels

    return bone_labels(_model("1k"))


def rest_pose() -> np.ndarray:
    """The identity pose ``(bone_count, 4, 4)``: anny's A-pose (arms 41° from the body, elbows bent 42°)."""
    return np.broadcast_to(np.eye(4), (len(_bone_labels()), 4, 4)).copy()


def joint_poses(angles: dict, n: int | None = None) -> np.ndarray:
    """Body poses ``(n, bone_count, 4, 4)`` from joint angles in degrees.

    Parameters
    ----------
    angles : dict mapping names of :data:`JOINT_LIMITS` to scalars or arrays ``(n,)`` (degrees);
        missing joints stay at rest. Each angle is clipped to its anatomical limits.
    n : number of poses; defaults to the length of the arrays (1 for scalars).
    """
    return poses_from_angles(_JOINTS, _bone_labels(), angles, n)


# -- actions -----------------------------------------------------------------------------------


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
    b = bump(t)
    return {**_both("shoulder_abduct", 115 * b), **_both("clavicle_elevate", 15 * b)}


def _knee_bend(t):
    b = bump(t)
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
    b = bump(t)
    return {
        **_both("shoulder_abduct", 120 * b),
        **_both("clavicle_elevate", 15 * b),
        **_both("elbow_flex", -20 * b),
        **_both("hip_abduct", 25 * b),
    }


def _punch(t):
    guard = bump(t)
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
    b = bump(t)
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
    g = bump(t)
    return {"shoulder_abduct.R": 95 * g, "elbow_flex.R": 70 * g, "shoulder_rotate.R": 25 * g * np.sin(6 * np.pi * t)}


def _forward_bend(t):
    b = bump(t)
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
    g = bump(t)
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


def action_angles(action: str, n_frames: int, *, amplitude: float = 1.0, offset: float = 0.0) -> dict:
    """Joint angles in degrees ``{name: (n_frames,)}`` of an action (before clipping to the limits)."""
    if action not in _ACTIONS:
        raise ValueError(f"unknown action {action!r}; known: {ACTIONS}.")
    t = phases(n_frames, offset)
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
