"""Heads with facial expressions, made offline with the body model anny (the paper's second kind of shape).

All heads share their faces and vertex order; a head is set by a *subject* (:mod:`opnet.data.subjects`) and
*expression weights* of anny's 52 facial actions (:data:`FACIAL_ACTIONS`, named mixes in
:data:`HEAD_EXPRESSIONS`). Vertices are float64 in metres, ``+z`` up, facing ``-y``.
"""

from __future__ import annotations

import functools

import numpy as np

from .motion import bump, phases
from .subjects import check_subjects

__all__ = [
    "FACIAL_ACTIONS",
    "HEAD_EXPRESSIONS",
    "head_faces",
    "head_vertices",
    "expression_sequence",
    "random_expressions",
]


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


def _model():
    from .anny_adapter import head_model

    return head_model()


@functools.lru_cache(maxsize=None)
def _head_component():
    """The head's largest connected component as ``(kept vertex indices, faces)``.

    Anny's head mesh has 4538 vertices in 4 components: the skin (with the mouth and eye cavities,
    open at the neck) and the separate eyeballs and tongue, which are dropped.
    """
    from ..mesh import Mesh
    from .anny_adapter import faces, template_vertices

    model = _model()
    mesh = Mesh(template_vertices(model), faces(model), keep_largest_component=True)
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
    return amplitude * bump(phases(n_frames, offset))[:, None] * _expression_vector(name)[None, :]


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
    subjects : (N, 6) phenotype values (:data:`~opnet.data.subjects.PHENOTYPES`).
    expression_weights : (N, n_actions) weights of :data:`FACIAL_ACTIONS` (e.g. :func:`expression_sequence`).
    """
    from .anny_adapter import evaluate

    subjects = check_subjects(subjects)
    weights = np.asarray(expression_weights, dtype=np.float64)
    if weights.shape != (len(subjects), len(FACIAL_ACTIONS)):
        raise ValueError(
            f"expression_weights must have shape ({len(subjects)}, {len(FACIAL_ACTIONS)}), got {weights.shape}."
        )
    # the head is not posed: the facial actions are blendshapes of the rest mesh
    return evaluate(
        _model(),
        subjects,
        read="rest_from_root",
        vertices=_head_component()[0],
        batch_size=batch_size,
        facial_actions=weights,
    )
