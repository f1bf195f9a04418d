"""Right hands making gestures, made offline with the body model anny.

All hands share their faces and vertex order; a hand is set by a *subject* (:mod:`opnet.data.subjects`) and a
*pose* built from named hand joint angles (:data:`HAND_JOINT_LIMITS`, in degrees; named gestures in
:data:`HAND_GESTURES`). Vertices are float64 in metres, the wrist joint at the origin.
"""

from __future__ import annotations

import numpy as np

from .motion import bump, check_poses, phases, poses_from_angles
from .subjects import check_subjects

__all__ = [
    "HAND_JOINT_LIMITS",
    "HAND_GESTURES",
    "hand_faces",
    "hand_vertices",
    "hand_poses",
    "gesture_sequence",
    "random_hand_poses",
]


def _model():
    from .anny_adapter import hand_model

    return hand_model()


def hand_faces() -> np.ndarray:
    """Triangles ``(3196, 3)`` int64 of the hand (1609 vertices, one component, open at the wrist)."""
    from .anny_adapter import faces

    return faces(_model())


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
    """Hand poses ``(n, 21, 4, 4)`` from hand joint angles in degrees (see :func:`opnet.data.humans.joint_poses`)."""
    from .anny_adapter import bone_labels

    return poses_from_angles(_HAND_JOINTS, bone_labels(_model()), angles, n)


def gesture_sequence(name: str, n_frames: int, *, amplitude: float = 1.0, offset: float = 0.0) -> np.ndarray:
    """Hand poses ``(n_frames, 21, 4, 4)`` closing smoothly from rest into a gesture (its joint angles
    scaled by ``amplitude``) and back, at phases ``(k + offset) / n_frames``.
    """
    if name not in HAND_GESTURES:
        raise ValueError(f"unknown gesture {name!r}; known: {tuple(HAND_GESTURES)}.")
    ramp = amplitude * bump(phases(n_frames, offset))
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
    from .anny_adapter import bone_labels, evaluate

    model = _model()
    subjects = check_subjects(subjects)
    poses = check_poses(poses, len(bone_labels(model)), len(subjects)).copy()
    poses[:, 0] = np.eye(4)
    return evaluate(model, subjects, read="posed_in_rest_root", batch_size=batch_size, pose_parameters=poses)
