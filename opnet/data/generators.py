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

__all__ = ["PRESETS", "GENERATORS", "GENERATOR_VERSION"]

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
    split = make_splits(subject, motion, rng, n_test_subjects=preset.test_subjects,
                        n_val_subcollections=preset.val_subcollections, held_out_groups={"random"})
    sub = np.array([f"subject{s:02d}/{m}" for s, m in zip(subject, motion)])
    return subject, motion, frame, split, sub


def _build(preset: str, seed: int, meta: dict, progress, *, motions, sequence, random, evaluate, rest, faces,
           reference=None):
    """A collection: ``sequence(motion, n_frames, amplitude=, offset=)`` and ``random(n, rng)`` give per-shape
    controls (poses or expression weights), ``evaluate(subjects, controls)`` the vertices; ``rest`` is the
    base's control. ``reference(subjects, controls)``, if given, evaluates the shapes on which the
    evaluation subset is chosen (so that every resolution gets the same subset)."""
    p = PRESETS[preset]
    rng = np.random.default_rng(seed)
    subjects = bodies.random_subjects(p.subjects, rng)
    subject, motion, frame, split, sub = _design(p, motions, rng)
    amplitude = rng.uniform(0.7, 1.0, p.subjects)  # each person moves a little differently...
    offset = rng.uniform(0.05, 0.45, (p.subjects, len(motions)))  # ...and is caught at other instants
    controls = np.empty((len(subject), *rest.shape))
    for s in range(p.subjects):
        for j, m in enumerate(motions):
            controls[(subject == s) & (motion == m)] = sequence(m, p.frames, amplitude=amplitude[s], offset=offset[s, j])
        controls[(subject == s) & (motion == "random")] = random(p.random, rng)
    vertices = evaluate(subjects[subject], controls)
    base = evaluate(np.array([bodies.AVERAGE_SUBJECT]), rest[None])[0]
    params = dict(phenotypes=subjects[subject], motion=motion, frame=frame, controls=controls.astype(np.float32))
    fps_vertices = None if reference is None else reference(subjects[subject], controls)
    return assemble(vertices, faces, base, split, sub, params, meta, progress=progress, fps_vertices=fps_vertices)


def _humans(preset, resolution, seed, meta, progress=None):
    one_k = None if resolution == "1k" else (lambda subj, poses: bodies.human_vertices(subj, poses, "1k"))
    return _build(preset, seed, meta, progress, motions=bodies.ACTIONS, sequence=bodies.action_poses,
                  random=bodies.random_poses, evaluate=lambda subj, poses: bodies.human_vertices(subj, poses, resolution),
                  rest=bodies.rest_pose(), faces=bodies.human_faces(resolution), reference=one_k)


def _heads(preset, resolution, seed, meta, progress=None):
    return _build(preset, seed, meta, progress, motions=tuple(bodies.HEAD_EXPRESSIONS),
                  sequence=bodies.expression_sequence, random=bodies.random_expressions,
                  evaluate=bodies.head_vertices, rest=np.zeros(len(bodies.FACIAL_ACTIONS)), faces=bodies.head_faces())


def _hands(preset, resolution, seed, meta, progress=None):
    return _build(preset, seed, meta, progress, motions=tuple(bodies.HAND_GESTURES),
                  sequence=bodies.gesture_sequence, random=bodies.random_hand_poses,
                  evaluate=bodies.hand_vertices, rest=bodies.hand_poses({}, 1)[0], faces=bodies.hand_faces())


#: name -> (generator, resolutions it offers; the first is the default)
GENERATORS = {
    "humans": (_humans, tuple(bodies.RESOLUTIONS)),
    "heads": (_heads, ("native",)),
    "hands": (_hands, ("native",)),
}
