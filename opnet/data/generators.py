"""Generators of the named collections: humans in motion, heads with expressions, hands with gestures.

Each draws its subjects and motions from one seeded ``numpy.random.Generator`` before any mesh is
evaluated, so the 1k, 2k and 5k-vertex versions of the human collection hold the same shapes, splits
and parameters. The base shape is the average subject at rest (rest pose, neutral face, open hand).
Heads and hands play the subjects' expressions and gestures as the humans play motions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import bodies
from .collections import assemble
from .splits import make_splits

__all__ = [
    "PRESETS",
    "GENERATORS",
    "MOTIONS",
    "shape_count",
    "GENERATOR_VERSION",
    "generate_shapes",
    "interpolate_controls",
    "resolution_map",
]

# Bump when a generator changes what it produces: cached collections then no longer match.
GENERATOR_VERSION = "2"


@dataclass(frozen=True)
class Preset:
    subjects: int  # body types
    frames: int  # frames per motion sequence
    random: int  # randomly posed shapes per subject
    test_subjects: int  # subjects held out entirely ("test_subjects")
    val_subcollections: int  # (subject, motion) sequences held out for validation


PRESETS = {
    "quick": Preset(subjects=8, frames=4, random=2, test_subjects=2, val_subcollections=3),
    "default": Preset(subjects=24, frames=16, random=20, test_subjects=3, val_subcollections=8),
    "paper": Preset(subjects=48, frames=28, random=40, test_subjects=5, val_subcollections=20),
}


def _design(preset: Preset, motions, rng: np.random.Generator):
    """Per-shape subject index, motion name and frame index: every subject performs every motion, plus random poses."""
    subject, motion, frame = [], [], []
    for s in range(preset.subjects):
        for m in motions:
            subject += [s] * preset.frames
            motion += [m] * preset.frames
            frame += list(range(preset.frames))
        subject += [s] * preset.random
        motion += ["random"] * preset.random
        frame += list(range(preset.random))
    subject, motion, frame = np.array(subject), np.array(motion), np.array(frame)
    split = make_splits(
        subject,
        motion,
        rng,
        n_test_subjects=preset.test_subjects,
        n_val_subcollections=preset.val_subcollections,
        held_out_groups={"random"},
    )
    sub = np.array([f"subject{s:02d}/{m}" for s, m in zip(subject, motion)])
    return subject, motion, frame, split, sub


def _build(
    preset: str, seed: int, meta: dict, progress, *, motions, sequence, random, evaluate, rest, faces, reference=None
):
    """A collection: ``sequence(motion, n_frames, amplitude=, offset=)`` and ``random(n, rng)`` give per-shape
    controls (poses or expression weights), ``evaluate(subjects, controls)`` the vertices; ``rest`` is the
    base's control. ``reference(subjects, controls)``, if given, evaluates the shapes on which the
    evaluation subset is chosen (so that every resolution gets the same subset).
    """
    p = PRESETS[preset]
    rng = np.random.default_rng(seed)
    subjects = bodies.random_subjects(p.subjects, rng)
    subject, motion, frame, split, sub = _design(p, motions, rng)
    amplitude = rng.uniform(0.7, 1.0, p.subjects)  # each person moves a little differently...
    offset = rng.uniform(0.05, 0.45, (p.subjects, len(motions)))  # ...and is caught at other instants
    controls = np.empty((len(subject), *rest.shape))
    for s in range(p.subjects):
        for j, m in enumerate(motions):
            controls[(subject == s) & (motion == m)] = sequence(
                m, p.frames, amplitude=amplitude[s], offset=offset[s, j]
            )
        controls[(subject == s) & (motion == "random")] = random(p.random, rng)
    vertices = evaluate(subjects[subject], controls)
    base = evaluate(np.array([bodies.AVERAGE_SUBJECT]), rest[None])[0]
    params = dict(phenotypes=subjects[subject], motion=motion, frame=frame, controls=controls.astype(np.float32))
    fps_vertices = None if reference is None else reference(subjects[subject], controls)
    return assemble(vertices, faces, base, split, sub, params, meta, progress=progress, fps_vertices=fps_vertices)


def _evaluator(name: str, resolution: str):
    """``evaluate(subjects (N, 6), controls (N, ...)) → vertices (N, n, 3)`` of a named collection."""
    if name == "humans":
        return lambda subj, poses: bodies.human_vertices(subj, poses, resolution)
    return {"heads": bodies.head_vertices, "hands": bodies.hand_vertices}[name]


#: name -> the motion sequences every subject performs (body actions, facial expressions, hand gestures)
MOTIONS = {"humans": bodies.ACTIONS, "heads": tuple(bodies.HEAD_EXPRESSIONS), "hands": tuple(bodies.HAND_GESTURES)}


def shape_count(name: str, preset: str) -> int:
    """How many shapes the collection ``name`` holds at ``preset`` (each subject: every motion, plus random poses)."""
    p = PRESETS[preset]
    return p.subjects * (len(MOTIONS[name]) * p.frames + p.random)


def _humans(preset, resolution, seed, meta, progress=None):
    one_k = None if resolution == "1k" else _evaluator("humans", "1k")
    return _build(
        preset,
        seed,
        meta,
        progress,
        motions=MOTIONS["humans"],
        sequence=bodies.action_poses,
        random=bodies.random_poses,
        evaluate=_evaluator("humans", resolution),
        rest=bodies.rest_pose(),
        faces=bodies.human_faces(resolution),
        reference=one_k,
    )


def _heads(preset, resolution, seed, meta, progress=None):
    return _build(
        preset,
        seed,
        meta,
        progress,
        motions=MOTIONS["heads"],
        sequence=bodies.expression_sequence,
        random=bodies.random_expressions,
        evaluate=_evaluator("heads", resolution),
        rest=np.zeros(len(bodies.FACIAL_ACTIONS)),
        faces=bodies.head_faces(),
    )


def _hands(preset, resolution, seed, meta, progress=None):
    return _build(
        preset,
        seed,
        meta,
        progress,
        motions=MOTIONS["hands"],
        sequence=bodies.gesture_sequence,
        random=bodies.random_hand_poses,
        evaluate=_evaluator("hands", resolution),
        rest=bodies.hand_poses({}, 1)[0],
        faces=bodies.hand_faces(),
    )


#: name -> (generator, resolutions it offers; the first is the default)
GENERATORS = {
    "humans": (_humans, tuple(bodies.RESOLUTIONS)),
    "heads": (_heads, ("native",)),
    "hands": (_hands, ("native",)),
}


def _generated(collection) -> str:
    name = collection.meta.get("name")
    if name not in GENERATORS or not {"phenotypes", "controls"} <= set(collection.params):
        raise ValueError(
            f"this collection ({name!r}) was not made by a generator of {sorted(GENERATORS)}, so its "
            "shapes cannot be generated anew; use opnet.data.load_collection('humans' | 'heads' | 'hands')."
        )
    return name


def generate_shapes(collection, phenotypes, controls, *, resolution: str | None = None) -> np.ndarray:
    """New shapes of a generated collection's kind, on its mesh: vertices ``(N, n, 3)`` float64 (metres).

    ``resolution`` (humans: a key of :data:`opnet.data.bodies.RESOLUTIONS`) gives the same shapes on another
    triangulation instead, whose faces are ``bodies.human_faces(resolution)``: the 2k and 5k meshes that
    :mod:`opnet.matching` maps onto a 1k base. ``phenotypes`` ``(N, 6)`` and ``controls`` ``(N, ...)`` are
    generator parameters like the collection's own
    ``params["phenotypes"]`` and ``params["controls"]`` (body or hand poses ``(bones, 4, 4)``, or facial
    expression weights): mixing one shape's body with another's pose gives a shape the collection does not hold,
    with its ground truth (the analogy benchmark of :mod:`opnet.apps`).
    """
    name = _generated(collection)
    phenotypes, controls = np.asarray(phenotypes, np.float64), np.asarray(controls, np.float64)
    expected = collection.params["controls"].shape[1:]
    if phenotypes.ndim != 2 or controls.shape[1:] != expected or len(controls) != len(phenotypes):
        raise ValueError(
            f"phenotypes must be (N, {len(bodies.PHENOTYPES)}) and controls (N, {', '.join(map(str, expected))}) "
            f"with the same N, got {phenotypes.shape} and {controls.shape}."
        )
    if resolution is None:
        resolution = collection.meta.get("resolution")
    elif name != "humans" or resolution not in bodies.RESOLUTIONS:
        raise ValueError(
            f"resolution applies to the humans, one of {list(bodies.RESOLUTIONS)}; got {resolution!r} for the {name}."
        )
    return _evaluator(name, resolution)(phenotypes, controls)


def resolution_map(collection, resolution: str):
    """The generator's own correspondence between its ``resolution`` mesh and the collection's base: the sparse
    ``(n_resolution, n_base)`` barycentric map of the base's rest shape on one triangulation onto the other (closest
    points, :func:`opnet.matching.closest_point_map`). The same for every shape, since both meshes are rigged alike:
    the true map that computed maps of ``generate_shapes(..., resolution=)`` are measured against.
    """
    from ..matching import closest_point_map
    from ..mesh import Mesh

    rest = generate_shapes(
        collection, np.array([bodies.AVERAGE_SUBJECT]), bodies.rest_pose()[None], resolution=resolution
    )[0]
    return closest_point_map(collection.base_basis, Mesh(rest, bodies.human_faces(resolution))).to_base


def interpolate_controls(collection, c0, c1, t) -> np.ndarray:
    """The generator's in-between controls ``(len(t), ...)`` of two shapes' controls ``c0``, ``c1`` at ``t`` ∈ [0, 1].

    Poses (humans, hands): each bone's local rotation is interpolated along the shortest arc (slerp, so a joint
    turns at a constant rate about a fixed axis). Expressions (heads): the blendshape weights linearly.
    """
    _generated(collection)
    c0, c1 = np.asarray(c0, np.float64), np.asarray(c1, np.float64)
    t = np.atleast_1d(np.asarray(t, np.float64))
    if c0.ndim == 1:  # expression weights
        return (1 - t)[:, None] * c0 + t[:, None] * c1
    from scipy.spatial.transform import Rotation

    r0 = Rotation.from_matrix(c0[:, :3, :3])
    step = (r0.inv() * Rotation.from_matrix(c1[:, :3, :3])).as_rotvec()  # (bones, 3)
    out = np.broadcast_to(np.eye(4), (len(t), *c0.shape)).copy()
    for i, s in enumerate(t):
        out[i, :, :3, :3] = (r0 * Rotation.from_rotvec(s * step)).as_matrix()
        out[i, :, :3, 3] = (1 - s) * c0[:, :3, 3] + s * c1[:, :3, 3]
    return out
