"""Generators of the named collections: humans in motion, heads with expressions, hands with gestures, animals
(:mod:`opnet.data.animals`: species and their blends on one template, posed by their clips).

Each draws its subjects and motions from one seeded ``numpy.random.Generator`` before any mesh is
evaluated, so the 1k, 2k and 5k-vertex versions of the human collection hold the same shapes, splits
and parameters. The base shape is the average subject at rest (rest pose, neutral face, open hand).
Heads and hands play the subjects' expressions and gestures as the humans play motions.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .._deprecation import renamed_keyword
from .._files import build_lock
from . import animals, hands, heads, humans
from .build import assemble
from .splits import make_splits
from .storage import BYTES_PER_SHAPE, Collection, check_root, default_root, read_collection, save_or_warn
from .subjects import AVERAGE_SUBJECT, random_subjects

__all__ = [
    "load_collection",
    "PRESETS",
    "GENERATORS",
    "MOTIONS",
    "shape_count",
    "GENERATOR_VERSION",
    "generate_shapes",
    "interpolate_controls",
    "resolution_map",
    "BODIES",
    "POSES",
]

#: Bumped when a generator changes what it produces: cached collections then no longer match.
GENERATOR_VERSION = "2"


@dataclass(frozen=True)
class Preset:
    subjects: int  # body types
    frames: int  # frames per motion sequence
    random: int  # randomly posed shapes per subject
    test_subjects: int  # subjects held out entirely ("test_subjects")
    val_subcollections: int  # (subject, motion) sequences held out for validation


#: The named presets' sizes: body types (``subjects``), ``frames`` per motion sequence, ``random`` poses per
#: subject, unseen ``test_subjects``, and (subject, motion) sequences held out for validation.
PRESETS = {
    "quick": Preset(subjects=8, frames=4, random=2, test_subjects=2, val_subcollections=3),
    "default": Preset(subjects=24, frames=16, random=20, test_subjects=3, val_subcollections=8),
    "paper": Preset(subjects=48, frames=28, random=40, test_subjects=5, val_subcollections=20),
}


#: How the training shapes of a generated collection get their bodies (``load_collection(bodies=)``): ``"subject"``
#: (the collections' design: each subject's body in all its sequences), ``"sequence"`` (a body drawn anew for each
#: training sequence), ``"shape"`` (for each training shape) or ``"mixed"`` (every other training shape keeps its
#: subject's body, the others get one of their own). The held-out splits keep their subjects' bodies, so ``val`` and
#: the test sets are the same shapes whatever the choice: only the number of distinct bodies the network trains on
#: changes, not the number of shapes.
BODIES = ("subject", "sequence", "shape", "mixed")
#: How the training shapes of a generated collection get their poses (``load_collection(poses=)``): ``"sequence"`` (the
#: collections' design: each subject performs every motion, plus a few random poses), ``"quarter"`` (every fourth
#: training shape of a motion sequence gets a random pose instead), ``"mixed"`` (every other one: those of
#: ``"quarter"`` and as many more) or ``"random"`` (every training shape a random pose). The random poses (or
#: expressions, or hand poses) come from the function the held-out random shapes come from, drawn from a stream of
#: their own; as with :data:`BODIES`, the held-out shapes and the shape count stay the same.
POSES = ("sequence", "quarter", "mixed", "random")


def _new_bodies(bodies: str, subject, motion, split, seed: int, draw):
    """Each training shape's new body index and the new bodies' phenotypes ``(B, 6)`` for ``bodies`` (:data:`BODIES`),
    drawn by ``draw(n, rng)`` from a stream of their own (``default_rng([seed, 1])``: the other draws are unchanged).
    """
    train = np.flatnonzero(split == "train")
    if bodies == "mixed":  # every other training shape: the others keep their subject's body
        train = train[1::2]
    if len(train) == 0:
        raise ValueError(f"bodies={bodies!r} draws bodies for training shapes, and this design has none to draw for.")
    if bodies == "sequence":
        _, which = np.unique(np.stack([subject[train], motion[train]]).astype(str), axis=1, return_inverse=True)
    else:
        which = np.arange(len(train))
    return train, which.ravel(), draw(int(which.max()) + 1, np.random.default_rng([seed, 1]))


def _new_poses(poses: str, motion, split) -> np.ndarray:
    """The training shapes that :data:`POSES`' ``poses`` gives a random pose instead of their sequence's."""
    reposed = np.flatnonzero((split == "train") & (motion != "random"))
    step = {"quarter": 4, "mixed": 2}.get(poses)  # "random": every one
    return reposed if step is None else reposed[1::step]


def _design(preset: Preset, motions, rng: np.random.Generator):
    """Per-shape subject index, motion name, frame index, split, sub-collection and subject name: every subject
    performs every motion, plus random poses.
    """
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
    names = np.array([f"subject{s:02d}" for s in subject])
    sub = np.array([f"{name}/{m}" for name, m in zip(names, motion)])
    return subject, motion, frame, split, sub, names


def _build(
    preset: str,
    seed: int,
    meta: dict,
    progress,
    *,
    motions,
    sequence,
    random,
    evaluate,
    rest,
    faces,
    reference=None,
    bodies: str = "subject",
    poses: str = "sequence",
):
    """A collection: ``sequence(motion, n_frames, amplitude=, offset=)`` and ``random(n, rng)`` give per-shape
    controls (poses or expression weights), ``evaluate(subjects, controls)`` the vertices; ``rest`` is the
    base's control. ``reference(subjects, controls)``, if given, evaluates the shapes on which the
    evaluation subset is chosen (so that every resolution gets the same subset). ``bodies``: :data:`BODIES`;
    ``poses``: :data:`POSES`.
    """
    p = PRESETS[preset]
    rng = np.random.default_rng(seed)
    subjects = random_subjects(p.subjects, rng)
    subject, motion, frame, split, sub, names = _design(p, motions, rng)
    phenotypes = subjects[subject]
    if bodies != "subject":  # the training shapes' bodies drawn anew; the held-out shapes' are untouched
        train, which, drawn = _new_bodies(bodies, subject, motion, split, seed, random_subjects)
        phenotypes[train] = drawn[which]
        names, sub = names.astype(object), sub.astype(object)
        names[train] = [f"body{j:04d}" for j in which]
        sub[train] = [f"{n}/{m}" for n, m in zip(names[train], motion[train])]
        names, sub = names.astype(str), sub.astype(str)
    amplitude = rng.uniform(0.7, 1.0, p.subjects)  # each person moves a little differently...
    offset = rng.uniform(0.05, 0.45, (p.subjects, len(motions)))  # ...and is caught at other instants
    controls = np.empty((len(subject), *rest.shape))
    for s in range(p.subjects):
        for j, m in enumerate(motions):
            controls[(subject == s) & (motion == m)] = sequence(
                m, p.frames, amplitude=amplitude[s], offset=offset[s, j]
            )
        controls[(subject == s) & (motion == "random")] = random(p.random, rng)
    if poses != "sequence":  # random poses for training shapes, from a stream of their own: the other draws unchanged
        reposed = _new_poses(poses, motion, split)
        if len(reposed) == 0:
            raise ValueError(f"poses={poses!r} re-poses training shapes of motions, and this design has none.")
        controls[reposed] = random(len(reposed), np.random.default_rng([seed, 2]))
        motion, frame, sub = motion.astype(object), frame.copy(), sub.astype(object)
        motion[reposed], frame[reposed] = "random", -1  # no longer a frame of a motion: frame -1 marks it
        sub[reposed] = [f"{n}/random" for n in names[reposed]]
        motion, sub = motion.astype(str), sub.astype(str)
    vertices = evaluate(phenotypes, controls)
    base = evaluate(np.array([AVERAGE_SUBJECT]), rest[None])[0]
    params = dict(phenotypes=phenotypes, motion=motion, frame=frame, controls=controls.astype(np.float32))
    fps_vertices = None if reference is None else reference(phenotypes, controls)
    return assemble(
        vertices, faces, base, split, sub, names, params, meta, progress=progress, fps_vertices=fps_vertices
    )


@dataclass(frozen=True)
class Design:
    """A generated collection of bodies in motion: its motions, how a frame of a motion and a random pose are drawn
    (``sequence(motion, n_frames, amplitude=, offset=)``, ``random(n, rng)``: per-shape controls), its shapes
    (``vertices(resolution)`` → ``evaluate(subjects, controls) → (N, n, 3)``), the base's control (``rest()``) and
    its faces (``faces(resolution)``) on each of its ``resolutions`` (the base's first).
    """

    motions: tuple
    sequence: Callable
    random: Callable
    vertices: Callable
    rest: Callable
    faces: Callable
    resolutions: tuple = ("native",)

    def build(self, preset, resolution, seed, meta, progress=None, **draws):
        """The collection at ``preset`` and ``resolution`` (:func:`load_collection`'s builder); on a resolution other
        than the base's, the evaluation subset is chosen on the base's shapes, so every resolution gets the same.
        """
        reference = None if resolution == self.resolutions[0] else self.vertices(self.resolutions[0])
        return _build(
            preset,
            seed,
            meta,
            progress,
            motions=self.motions,
            sequence=self.sequence,
            random=self.random,
            evaluate=self.vertices(resolution),
            rest=self.rest(),
            faces=self.faces(resolution),
            reference=reference,
            **draws,
        )


def _human_vertices(resolution):
    return lambda subjects, poses: humans.human_vertices(subjects, poses, resolution)


#: The generated collections of bodies in motion, by name.
DESIGNS = {
    "humans": Design(
        humans.ACTIONS,
        humans.action_poses,
        humans.random_poses,
        _human_vertices,
        humans.rest_pose,
        humans.human_faces,
        humans.RESOLUTIONS,
    ),
    "heads": Design(
        tuple(heads.HEAD_EXPRESSIONS),
        heads.expression_sequence,
        heads.random_expressions,
        lambda resolution: heads.head_vertices,
        lambda: np.zeros(len(heads.FACIAL_ACTIONS)),
        lambda resolution: heads.head_faces(),
    ),
    "hands": Design(
        tuple(hands.HAND_GESTURES),
        hands.gesture_sequence,
        hands.random_hand_poses,
        lambda resolution: hands.hand_vertices,
        lambda: hands.hand_poses({}, 1)[0],
        lambda resolution: hands.hand_faces(),
    ),
}


def _evaluator(name: str, resolution: str):
    """``evaluate(subjects, controls) → vertices (N, n, 3)`` of a named collection."""
    if name == "animals":  # "subjects": species weights (N, S); "controls": (clip, phase, turns)
        return lambda weights, poses: animals.registered_species().shapes(weights, poses)
    return DESIGNS[name].vertices(resolution)


#: name -> the motion sequences every subject performs (body actions, facial expressions, hand gestures)
MOTIONS = {name: d.motions for name, d in DESIGNS.items()}


def shape_count(name: str, preset: str) -> int:
    """How many shapes the collection ``name`` holds at ``preset`` (each subject: every motion, plus random poses;
    the animals: before their quality pass).
    """
    if name == "animals":
        return animals.shape_count(preset)
    p = PRESETS[preset]
    return p.subjects * (len(MOTIONS[name]) * p.frames + p.random)


def _animals(preset, resolution, seed, meta, progress=None, root=None):
    return animals.animal_collection(preset, seed, meta, root, progress)


#: name -> (generator, resolutions it offers; the first is the default)
GENERATORS = {name: (d.build, d.resolutions) for name, d in DESIGNS.items()} | {"animals": (_animals, ("native",))}


def generated_name(collection) -> str:
    name = collection.meta.get("name")
    if name not in GENERATORS or not {"phenotypes", "controls"} <= set(collection.params):
        raise ValueError(
            f"this collection ({name!r}) was not made by a generator of {sorted(GENERATORS)}, so its "
            "shapes cannot be generated anew; use opnet.data.load_collection('humans' | 'heads' | 'hands' | 'animals')."
        )
    return name


def generate_shapes(collection, phenotypes, controls, *, resolution: str | None = None) -> np.ndarray:
    """New shapes of a generated collection's kind, on its mesh: vertices ``(N, n, 3)`` float64 (metres).

    ``resolution`` (humans: one of :data:`opnet.data.humans.RESOLUTIONS`) gives the same shapes on another
    triangulation instead, whose faces are ``humans.human_faces(resolution)``: the 2k and 5k meshes that
    :mod:`opnet.matching` maps onto a 1k base. ``phenotypes`` ``(N, 6)`` (animals: species weights ``(N, S)``)
    and ``controls`` ``(N, ...)`` are generator parameters like the collection's own ``params["phenotypes"]`` and
    ``params["controls"]`` (body or hand poses ``(bones, 4, 4)``, facial expression weights, or the animals'
    ``(clip, phase, turns)``; an animals collection must have been built by this opnet's code, ``meta["builder"]``):
    mixing one shape's body with another's pose gives a shape the collection does not hold, with its ground truth
    (the analogy benchmark of :mod:`opnet.apps`).
    """
    name = generated_name(collection)
    phenotypes, controls = np.asarray(phenotypes, np.float64), np.asarray(controls, np.float64)
    expected = collection.params["controls"].shape[1:]
    width = collection.params["phenotypes"].shape[1]
    if phenotypes.shape[1:] != (width,) or controls.shape[1:] != expected or len(controls) != len(phenotypes):
        raise ValueError(
            f"phenotypes must be (N, {width}) and controls (N, {', '.join(map(str, expected))}) "
            f"with the same N, got {phenotypes.shape} and {controls.shape}."
        )
    if name == "animals" and collection.meta.get("builder") != animals.builder_digest():
        raise ValueError(
            f"this animals collection was built by other code or assets (builder {collection.meta.get('builder')}) "
            f"than this opnet's ({animals.builder_digest()}): its shapes would not match the generator's. Load it "
            "again with opnet.data.load_collection('animals', preset), which builds it with this code."
        )
    if resolution is None:
        resolution = collection.meta.get("resolution")
    elif resolution not in GENERATORS[name][1]:
        raise ValueError(f"the {name} come in the resolutions {list(GENERATORS[name][1])}; got {resolution!r}.")
    return _evaluator(name, resolution)(phenotypes, controls)


def resolution_map(collection, resolution: str):
    """The generator's own correspondence between its ``resolution`` mesh and the collection's base: the sparse
    ``(n_resolution, n_base)`` barycentric map of the base's rest shape on one triangulation onto the other (closest
    points, :func:`opnet.matching.closest_point_map`). The same for every shape, since both meshes are rigged alike:
    the true map that computed maps of ``generate_shapes(..., resolution=)`` are measured against.
    """
    from ..matching import closest_point_map
    from ..mesh import Mesh

    rest = generate_shapes(collection, np.array([AVERAGE_SUBJECT]), humans.rest_pose()[None], resolution=resolution)[0]
    return closest_point_map(collection.base_basis, Mesh(rest, humans.human_faces(resolution))).to_base


def interpolate_controls(collection, c0, c1, t) -> np.ndarray:
    """The generator's in-between controls ``(len(t), ...)`` of two shapes' controls ``c0``, ``c1`` at ``t`` ∈ [0, 1].

    Poses (humans, hands): each bone's local rotation is interpolated along the shortest arc (slerp, so a joint
    turns at a constant rate about a fixed axis). Expressions (heads): the blendshape weights linearly. Animals
    (``(clip, phase, turns)``, :mod:`opnet.data.animals`): two frames of one clip; the in-between follows the clip
    from one phase to the other (its own motion, linear in phase) while each joint's extra turn is slerped.
    """
    from scipy.spatial.transform import Rotation

    name = generated_name(collection)
    c0, c1 = np.asarray(c0, np.float64), np.asarray(c1, np.float64)
    t = np.atleast_1d(np.asarray(t, np.float64))
    if name == "animals":
        if c0[0] != c1[0]:
            raise ValueError(
                f"an animal's in-between poses are frames of one clip; c0 is of clip {int(c0[0])}, c1 of clip "
                f"{int(c1[0])}: give two poses of the same clip (params['controls'][:, 0] is the clip index, "
                "params['motion'] its name)."
            )
        turns = [
            r.as_rotvec().ravel() for r in _slerp(*(Rotation.from_rotvec(c[2:].reshape(-1, 3)) for c in (c0, c1)), t)
        ]
        return np.column_stack([np.full(len(t), c0[0]), (1 - t) * c0[1] + t * c1[1], np.array(turns)])
    if c0.ndim == 1:  # expression weights
        return (1 - t)[:, None] * c0 + t[:, None] * c1

    out = np.broadcast_to(np.eye(4), (len(t), *c0.shape)).copy()
    for i, (s, r) in enumerate(
        zip(t, _slerp(Rotation.from_matrix(c0[:, :3, :3]), Rotation.from_matrix(c1[:, :3, :3]), t))
    ):
        out[i, :, :3, :3] = r.as_matrix()
        out[i, :, :3, 3] = (1 - s) * c0[:, :3, 3] + s * c1[:, :3, 3]
    return out


def _slerp(r0, r1, t) -> list:
    """Each rotation of the stack ``r0`` (a scipy ``Rotation``) turned towards ``r1``'s along the shortest arc, at
    each ``t`` ∈ [0, 1]: a list of ``len(t)`` stacks.
    """
    from scipy.spatial.transform import Rotation

    step = (r0.inv() * r1).as_rotvec()
    return [r0 * Rotation.from_rotvec(s * step) for s in t]


def stem_name(meta: dict) -> str:
    """The file name (without extensions) of a generated collection: ``<name>-<preset>-<resolution>-seed<seed>-v<N>``,
    then ``-bodies-<bodies>`` and ``-poses-<poses>`` when they are not the design's (:data:`BODIES`, :data:`POSES`).
    The generator version is part of it: after an upgrade that changes the data, the collection is rebuilt; so is
    the animals' builder digest (``-<8 hex>``: their code and the asset package's version).
    """
    stem = f"{meta['name']}-{meta['preset']}-{meta['resolution']}-seed{meta['seed']}-v{meta['generator_version']}"
    stem += f"-bodies-{meta['bodies']}" if "bodies" in meta else ""
    stem += f"-poses-{meta['poses']}" if "poses" in meta else ""
    return stem + (f"-{meta['builder'][:8]}" if "builder" in meta else "")


@renamed_keyword("kinds", "channels")
def load_collection(
    name: str,
    preset: str = "quick",
    root=None,
    *,
    resolution: str | None = None,
    seed: int = 0,
    rebuild: bool = False,
    progress: bool | None = None,
    channels=None,
    bodies: str = "subject",
    poses: str = "sequence",
) -> Collection:
    """The collection ``name`` (``"humans"``, ``"heads"``, ``"hands"`` or ``"animals"``) at ``preset``, built if
    missing.

    ``preset`` is ``"quick"`` (a few hundred shapes, for tests), ``"default"`` (several thousand, minutes on a
    laptop CPU) or ``"paper"`` (≈17 000 training shapes like the paper's). ``resolution`` (humans only) picks
    the ``"1k"`` (default), ``"2k"`` or ``"5k"``-vertex version of the same shapes. A cached file is reused when
    its parameters match; a corrupt or mismatched one raises :class:`~opnet.data.CollectionError` naming the fix
    (``rebuild=True``). One process builds a collection at a time: another that asks for it meanwhile waits (a lock
    file beside it, released by the OS if the builder dies; none on Windows, in a read-only root or on a file system
    without locks) and reads what the first saved.

    ``channels``: the channels wanted (names or inner products, in order; default :data:`opnet.KINDS`). The
    collection is built and stored with the paper's three; others are added by :meth:`Collection.with_channels` and
    cached beside
    it, so asking for a new channel never rebuilds the shapes.

    ``bodies`` (:data:`BODIES`) and ``poses`` (:data:`POSES`), generated humans, heads and hands: the training
    shapes' bodies and poses drawn anew (more distinct bodies, more random poses) at the same shape count; ``val``
    and the test sets stay the same shapes, bit for bit. Each choice is a collection of its own (``-bodies-<kind>``,
    ``-poses-<kind>`` in the file name).
    """
    if name not in GENERATORS:
        raise ValueError(
            f"unknown collection {name!r}; use one of {sorted(GENERATORS)} (or load_folder for your own meshes)."
        )
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; use one of {list(PRESETS)}.")
    generate, resolutions = GENERATORS[name]
    resolution = resolutions[0] if resolution is None else resolution
    if resolution not in resolutions:
        raise ValueError(f"the {name} collection comes in resolutions {list(resolutions)}, not {resolution!r}.")
    try:
        seed = operator.index(seed)
    except TypeError:
        raise ValueError(f"seed must be an integer, got {seed!r}.") from None
    root = Path(root) if root is not None else default_root()
    meta = dict(name=name, preset=preset, resolution=resolution, seed=seed, generator_version=GENERATOR_VERSION)
    extra = {}
    for key, value, options in (("bodies", bodies, BODIES), ("poses", poses, POSES)):
        if value not in options:
            raise ValueError(f"{key} must be one of {list(options)}, got {value!r}.")
        if value != options[0]:
            if name == "animals":
                raise ValueError(
                    f"{key}= draws new human, head or hand {key}; the animals' bodies are blends of their species "
                    f"and their poses come from their clips: leave {key}={options[0]!r} for them."
                )
            meta[key] = extra[key] = value
    if bodies == "mixed" and poses in ("quarter", "mixed"):
        raise ValueError(
            f"bodies='mixed' and poses={poses!r} pick the same training shapes (every other one), so the new bodies "
            "would be the only ones posed at random: combine poses= with bodies='subject', 'sequence' or 'shape'."
        )
    if name == "animals":  # keyed by their code and the asset package's version; the registrations kept in root
        meta["builder"] = animals.builder_digest()
        extra["root"] = root
    stem = root / stem_name(meta)
    manifest = stem.with_name(stem.name + ".json")
    if not rebuild and manifest.is_file():
        coll = read_collection(stem, expected_meta=meta)
    else:  # one builder at a time: a second process waits for the first, then reads what it saved
        with build_lock(stem.with_name(f".{stem.name}.lock"), f"the {name} collection ({preset})"):
            if not rebuild and manifest.is_file():
                coll = read_collection(stem, expected_meta=meta)
            else:
                check_root(root, shape_count(name, preset) * BYTES_PER_SHAPE)
                coll = generate(preset=preset, resolution=resolution, seed=seed, meta=meta, progress=progress, **extra)
                save_or_warn(coll, stem)
    return coll if channels is None else coll.with_channels(channels, progress=progress)
