"""The animals collection: every shape on one template (the horse's body), bodies from the registered species and
blends between them, posed by the species' own clips.

- **Bodies**: the eleven distinct species (``horse_white`` is the horse's geometry), each registered onto the
  template (:func:`registered_species`), and blends of two species ``(1 − w) · a + w · b`` with ``w`` uniform in
  ``[0.3, 0.7]``: a continuous shape space between them, like SMAL's. A body is its species weights ``(S,)``, the
  collection's ``params["phenotypes"]``.
- **Poses**: the clips every species has (:attr:`Bodies.clips`, nine: walk, gallop, eating, idle, death …), each a
  sequence of frames evenly spaced in phase (each body caught at its own instants), plus random poses: a clip that
  the body trains on (never one held out for it) at a random phase, with the trunk, neck, head and tail turned
  further by normal random rotations (standard deviation :data:`TURN` rad about each local axis; the legs are left
  to the clips: their hooves and paws hang on IK bones that a turn of the leg would not carry). A pose is
  ``(clip index, phase in [0, 1], turns (J, 3))``, the ``params["controls"]``.
  A blend is posed by posing each of its species with the same pose (its own clip's keys at that phase) and blending
  the posed meshes with the body's weights.
- **Quality**: a posed shape whose worst triangle has quality ``4√3·area/Σedge²`` below :data:`MIN_QUALITY` is
  refused and counted (``meta["refused"]``); every shape has the template's faces, one closed genus-0 surface.
- **Splits**: as the humans' (``subject`` = the body, ``subcollection`` = body/clip): whole clips of seen bodies
  held out (``test``, ``val``), and held-out bodies (``test_subjects``): the species :data:`UNSEEN_SPECIES`, never
  seen in training, with every blend that has it, and a few other blends.

The registrations are built once (about a minute) and cached beside the collections, keyed (:func:`builder_digest`)
by this subpackage's code and the asset package's version.
"""

from __future__ import annotations

import ast
import dataclasses
import hashlib
import importlib.util
import inspect
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..._files import atomic_write
from ...mesh import face_quality
from ..build import assemble
from ..splits import make_splits
from . import assets, registration, rig, template
from .assets import asset_version, read_rig, species
from .registration import body_part, registered_rig
from .template import body_template

__all__ = [
    "TEMPLATE_SPECIES",
    "UNSEEN_SPECIES",
    "MIN_QUALITY",
    "TURN",
    "AnimalPreset",
    "PRESETS",
    "Bodies",
    "builder_digest",
    "registered_species",
    "shape_count",
    "body_design",
    "animal_collection",
]

#: The species whose body is the template (its rest pose is the base shape).
TEMPLATE_SPECIES = "horse"
#: The species held out of training entirely, with every blend that has it (in ``test_subjects``).
UNSEEN_SPECIES = "wolf"
#: The worst face quality a shape may have (the human collections' worst is 1.2e-3).
MIN_QUALITY = 1e-3
#: The standard deviation (rad) of the random poses' further turn of each trunk, neck, head and tail joint.
TURN = 0.15


@dataclass(frozen=True)
class AnimalPreset:
    blends: int  # bodies blended from two seen species
    unseen_blends: int  # bodies blended from the unseen species and a seen one (test_subjects)
    test_blends: int  # of the blends of seen species, how many are held out (test_subjects)
    frames: int  # frames per clip
    random: int  # random poses per body
    val_subcollections: int  # (body, clip) sequences held out for validation


#: The animal presets: 11 species + blends, each body playing every common clip (9) and random poses.
PRESETS = {
    "quick": AnimalPreset(blends=4, unseen_blends=1, test_blends=1, frames=3, random=2, val_subcollections=3),
    "default": AnimalPreset(blends=26, unseen_blends=2, test_blends=2, frames=5, random=5, val_subcollections=8),
    "paper": AnimalPreset(blends=64, unseen_blends=4, test_blends=4, frames=8, random=8, val_subcollections=20),
}


@dataclass(frozen=True, eq=False)
class Bodies:
    """The distinct species registered onto one template: ``species`` ``(S,)`` (the template's first), ``rigs``
    ``(S,)`` (:class:`~opnet.data.animals.rig.Rig` on the template's faces, each with its own skin, skeleton and
    clips), ``clips`` (those every species has) and ``joints`` (the nodes that random poses turn: the trunk, neck,
    head and tail joints every species has).
    """

    species: tuple
    rigs: tuple
    clips: tuple
    joints: tuple

    @property
    def faces(self) -> np.ndarray:
        """The template's triangles ``(m, 3)``."""
        return self.rigs[0].faces

    def shapes(self, weights, controls) -> np.ndarray:
        """Posed bodies ``(N, n, 3)`` float64 (m): species weights ``(N, S)`` and poses ``(N, 2 + 3J)`` (clip
        index into :attr:`clips`, phase in ``[0, 1]``, turns ``(J, 3)`` rad of :attr:`joints`, flattened).
        """
        weights, controls = np.asarray(weights, np.float64), np.asarray(controls, np.float64)
        if weights.shape[1:] != (len(self.species),) or controls.shape != (len(weights), 2 + 3 * len(self.joints)):
            raise ValueError(
                f"weights must be (N, {len(self.species)}) and controls (N, {2 + 3 * len(self.joints)}), got "
                f"{weights.shape} and {controls.shape}."
            )
        clip = controls[:, 0].astype(int)
        out = np.zeros((len(weights), len(self.rigs[0].vertices), 3))
        for s, animal in enumerate(self.rigs):
            nodes = [animal.node_names.index(name) for name in self.joints]
            for c in np.unique(clip[weights[:, s] != 0]):
                rows = np.flatnonzero((weights[:, s] != 0) & (clip == c))
                turns = np.zeros((len(rows), len(animal.node_names), 3))
                turns[:, nodes] = controls[rows, 2:].reshape(len(rows), -1, 3)
                times = controls[rows, 1] * animal.clip(self.clips[c]).duration
                out[rows] += weights[rows, s, None, None] * animal.pose(self.clips[c], times, turns)
        return out


def builder_digest() -> str:
    """16 hex digits naming what builds the animals: the code of this subpackage's modules and of the geometry they
    call (their syntax trees: comments, docstrings and layout left out), and the versions of the asset package and
    of the meshing libraries.
    """
    from importlib.metadata import PackageNotFoundError, version

    from ... import mesh, spectral

    h = hashlib.sha256(asset_version().encode())
    for package in ("pymeshlab", "pymeshfix"):
        try:
            h.update(f"{package} {version(package)}".encode())
        except PackageNotFoundError:
            h.update(f"{package} missing".encode())
    for module in (assets, rig, template, registration, mesh, spectral, _this_module()):
        h.update(ast.dump(_without_docstrings(ast.parse(inspect.getsource(module)))).encode())
    return h.hexdigest()[:16]


def _without_docstrings(tree: ast.Module) -> ast.Module:
    """``tree`` with the docstring of every module, class and function taken out (they do not change the data)."""
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (
            isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
            and body
            and isinstance(body[0], ast.Expr)
            and isinstance(body[0].value, ast.Constant)
            and isinstance(body[0].value.value, str)
        ):
            node.body = body[1:] or [ast.Pass()]
    return tree


def _this_module():
    import sys

    return sys.modules[__name__]


_REGISTERED: dict = {}  # builder digest -> Bodies, for this process


def registered_species(root=None, progress: bool | None = None) -> Bodies:
    """Every distinct species on the template of :data:`TEMPLATE_SPECIES` (:func:`~.template.body_template`, then
    :func:`~.registration.registered_rig` for the others), read from ``root`` (default the data folder) when built
    before by the same code and assets, else built (about 5 s a species) and stored there.
    """
    from tqdm.auto import tqdm

    from ..storage import default_root

    digest = builder_digest()
    path = (Path(root) if root is not None else default_root()) / f"animals-registered-{digest}.npz"
    built = digest not in _REGISTERED
    if built:
        names = _distinct_species()
        if path.is_file():
            with np.load(path) as stored:
                rigs = [
                    dataclasses.replace(
                        read_rig(name),
                        vertices=stored["vertices"][i],
                        faces=stored["faces"],
                        skin_joints=stored["skin_joints"][i],
                        skin_weights=stored["skin_weights"][i],
                    )
                    for i, name in enumerate(names)
                ]
        else:
            rigs = [body_template(read_rig(names[0]))]
            registered = _registered_rigs(rigs[0], names[1:])
            bar = dict(total=len(names) - 1, desc="registering species", unit="species", disable=progress is False)
            rigs += tqdm(registered, **bar)
        _REGISTERED[digest] = _bodies(names, rigs)
    bodies = _REGISTERED[digest]
    if not path.is_file() and (built or root is not None):  # built now, or earlier in this process for another root
        arrays = dict(
            vertices=np.stack([r.vertices for r in bodies.rigs]),
            faces=bodies.faces,
            skin_joints=np.stack([r.skin_joints for r in bodies.rigs]),
            skin_weights=np.stack([r.skin_weights for r in bodies.rigs]),
        )
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, lambda f: np.savez(f, **arrays))
    return bodies


def _registered_rigs(source, names: list):
    """:func:`~.registration.registered_rig` of ``source`` onto each species of ``names``, yielded in order: in
    joblib's own processes (loky, whatever backend the caller configured), one per core
    (:func:`opnet._parallel.usable_cores`); here, one after the other, on one core or where joblib (the ``data``
    extra) is missing. The rigs are the same either way, bit for bit (closest points, sparse solves and k-d trees take
    no thread count; ``tests/test_animal_collection.py`` compares the two).
    """
    from ..._parallel import usable_cores

    workers = min(usable_cores(), len(names))
    if workers <= 1 or importlib.util.find_spec("joblib") is None:
        yield from (registered_rig(source, read_rig(name)) for name in names)
        return
    import joblib

    with joblib.Parallel(n_jobs=workers, backend="loky", return_as="generator") as parallel:
        yield from parallel(joblib.delayed(_registered_onto)(source, name) for name in names)


def _registered_onto(source, name: str):
    """One species registered onto ``source`` in a worker process (which ends when its parent does)."""
    from ..._parallel import exit_with_parent

    exit_with_parent()
    return registered_rig(source, read_rig(name))


def _bodies(names: list, rigs: list) -> Bodies:
    """The :class:`Bodies` of registered ``rigs``: the clips and the turnable joints that they all have."""
    clips = tuple(sorted(set.intersection(*(set(r.clip_names) for r in rigs))))
    common = set.intersection(*(set(r.node_names) for r in rigs))
    first = rigs[0]
    skinned = {first.joint_names[j] for j in np.unique(first.skin_joints[first.skin_weights > 0])}
    joints = tuple(
        name for name in first.joint_names if name in common and body_part(name) in ("body", "tail") and name in skinned
    )
    return Bodies(tuple(names), tuple(rigs), clips, joints)


def _distinct_species() -> list:
    """The species with distinct bodies, :data:`TEMPLATE_SPECIES` first (``horse_white`` is the horse's mesh, 0.5 %
    smaller).
    """
    names, seen = [], []
    for name in [TEMPLATE_SPECIES] + [s for s in species() if s != TEMPLATE_SPECIES]:
        vertices = read_rig(name).vertices
        vertices = (vertices - vertices.mean(0)) / np.ptp(vertices, axis=0).max()  # the same shape at any size...
        vertices = vertices[np.lexsort(vertices.T)]  # ...and in any vertex order
        if not any(v.shape == vertices.shape and np.allclose(v, vertices, atol=1e-6) for v in seen):
            names.append(name)
            seen.append(vertices)
    return names


def shape_count(preset: str) -> int:
    """How many shapes the animals hold at ``preset`` before the quality pass (11 species, 9 common clips)."""
    p = PRESETS[preset]
    return (11 + p.blends + p.unseen_blends) * (9 * p.frames + p.random)


def body_design(species_names, preset: str, rng: np.random.Generator):
    """The bodies of the animals at ``preset``: species weights ``(B, S)``, names ``(B,)`` (distinct) and the indices
    of the bodies held out (``test_subjects``): the species ``species_names`` (:attr:`Bodies.species`), then the
    blends of seen species (the last ``test_blends`` of them held out), then those of the unseen species. A blend
    whose name (its species and rounded weights) another body already has is drawn again.
    """
    p = PRESETS[preset]
    species_names = list(species_names)
    s = len(species_names)
    unseen = species_names.index(UNSEEN_SPECIES)
    seen = [i for i in range(s) if i != unseen]
    weights, names = list(np.eye(s)), list(species_names)
    for k in range(p.blends + p.unseen_blends):
        while True:
            a, b = (unseen, rng.choice(seen)) if k >= p.blends else rng.choice(seen, 2, replace=False)
            w = rng.uniform(0.3, 0.7)
            name = f"{species_names[a]}{round(100 * (1 - w))}+{species_names[b]}{round(100 * w)}"
            if name not in names:
                break
        weights.append(np.zeros(s))
        weights[-1][[a, b]] = 1 - w, w
        names.append(name)
    weights = np.array(weights)
    held = np.r_[np.arange(s + p.blends - p.test_blends, s + p.blends), np.flatnonzero(weights[:, unseen] > 0)]
    return weights, np.array(names), held


def animal_collection(preset: str, seed: int, meta: dict, root=None, progress: bool | None = None):
    """The animals at ``preset`` (a :class:`~opnet.data.storage.Collection`; ``meta`` is stored with it and gains
    ``refused``, the shapes the quality pass dropped, by clip).
    """
    p = PRESETS[preset]
    bodies = registered_species(root, progress)
    rng = np.random.default_rng(seed)
    weights, names, held = body_design(bodies.species, preset, rng)
    body, motion, frame, controls = [], [], [], []
    for b in range(len(weights)):
        for c, clip in enumerate(bodies.clips):
            phase = (np.arange(p.frames) + rng.uniform(0.05, 0.45)) / p.frames  # each body caught at its own instants
            body += [b] * p.frames
            motion += [clip] * p.frames
            frame += range(p.frames)
            controls += [np.r_[c, u, np.zeros(3 * len(bodies.joints))] for u in phase]
        for k in range(p.random):  # their clips are drawn below, once the splits are known
            body.append(b)
            motion.append("random")
            frame.append(k)
            controls.append(np.r_[-1, rng.uniform(), rng.normal(0.0, TURN, 3 * len(bodies.joints))])
    body, motion, frame, controls = np.array(body), np.array(motion), np.array(frame), np.array(controls)
    split = make_splits(
        body,
        motion,
        rng,
        n_test_subjects=0,
        n_val_subcollections=p.val_subcollections,
        held_out_groups={"random"},
        unseen=held,
    )
    # a random pose takes the legs of a clip that its body trains on: never of a clip held out for it (test, val)
    for i in np.flatnonzero(motion == "random"):
        kept = sorted(
            {
                c
                for c, clip in enumerate(bodies.clips)
                if ((body == body[i]) & (motion == clip) & (split == split[i])).any()
            }
        )
        controls[i, 0] = rng.choice(kept)
    vertices = bodies.shapes(weights[body], controls)
    worst = face_quality(vertices, bodies.faces).min(-1)
    keep = worst >= MIN_QUALITY
    refused = {clip: int((~keep & (motion == clip)).sum()) for clip in (*bodies.clips, "random")}
    params = dict(phenotypes=weights[body][keep], motion=motion[keep], frame=frame[keep], controls=controls[keep])
    meta = dict(meta, refused={k: v for k, v in refused.items() if v}, species=list(bodies.species))
    sub = np.array([f"{n}/{m}" for n, m in zip(names[body], motion)])
    return assemble(
        vertices[keep],
        bodies.faces,
        bodies.rigs[0].vertices,
        split[keep],
        sub[keep],
        names[body][keep],
        params,
        meta,
        progress=progress,
    )
