"""Shape collections on disk: one documented format, written atomically, checked on load.

A collection is a set of meshes in 1-1 correspondence (shared faces) with, for every
shape, its three shape differences against a fixed base shape (fast path, ``k`` = 60 on
the base by default), its split label, its sub-collection and the parameters it was
generated from. On disk it is two files in ``root``:

``{stem}.npz``
    ``vertices`` (N, n, 3) float32 (metres for the body models), ``faces`` (m, 3) int64,
    ``operators`` (N, 3, k, k) float32 (channels: area, conformal, extrinsic),
    ``split`` (N,) str, ``subcollection`` (N,) str, ``base_vertices`` (n, 3) float64,
    ``base_evals`` (k,), ``base_evecs`` (n, k), ``base_mass`` (n,) float64 (the base
    eigenbasis every consumer must use), ``eval_subset`` (indices of the 50-shape
    evaluation subset), and ``param_<name>`` arrays (N, ...) of per-shape parameters.
``{stem}.json``
    the manifest: format and generator versions, name, preset, resolution, seed, k, the
    shapes of the arrays, and the SHA-256 of the ``.npz``.

Both files are written to a temporary name and renamed, data first, so an interrupted
build never leaves a pair that loads: a ``.npz`` without its manifest, or whose checksum
or parameters do not match, is rebuilt (or reported with :class:`CollectionError`).
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..mesh import Mesh, MeshError
from ..shape_difference import KINDS, shape_differences
from ..spectral import Eigenbasis, eigenbasis

__all__ = ["Collection", "CollectionError", "load_collection", "load_folder", "save_collection", "read_collection",
           "default_root", "FORMAT_VERSION"]

FORMAT_VERSION = 1


class CollectionError(RuntimeError):
    """A collection file that is missing, corrupt or built with other parameters; the message says how to rebuild."""


@dataclass(eq=False)
class Collection:
    """Shapes in correspondence with their shape differences (see the module docstring for the fields)."""

    vertices: np.ndarray
    faces: np.ndarray
    operators: np.ndarray
    split: np.ndarray
    subcollection: np.ndarray
    base_basis: Eigenbasis
    eval_subset: np.ndarray
    params: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.vertices)

    @property
    def channels(self) -> tuple[str, ...]:
        return KINDS

    def indices(self, split: str) -> np.ndarray:
        """Indices of the shapes of one split (``"train"``, ``"val"``, ``"test"``, ``"test_subjects"``)."""
        if split not in {"train", "val", "test", "test_subjects"}:
            raise ValueError(f"unknown split {split!r}; use 'train', 'val', 'test' or 'test_subjects'.")
        return np.flatnonzero(self.split == split)

    def mesh(self, i: int) -> Mesh:
        """Shape ``i`` as a :class:`opnet.Mesh` (float64)."""
        return Mesh(self.vertices[i].astype(np.float64), self.faces)

    def __repr__(self) -> str:
        counts = {s: int(np.sum(self.split == s)) for s in ("train", "val", "test", "test_subjects")}
        return (f"Collection({self.meta.get('name', '?')!r}, preset={self.meta.get('preset')!r}, shapes={len(self)}, "
                f"vertices={self.vertices.shape[1]}, k={self.base_basis.k}, splits={counts})")


def default_root() -> Path:
    """Where collections are cached: ``$OPNET_DATA_DIR`` or ``~/.cache/opnet``."""
    return Path(os.environ.get("OPNET_DATA_DIR", Path.home() / ".cache" / "opnet"))


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 22), b""):
            h.update(chunk)
    return h.hexdigest()


def _atomic_write(path: Path, write) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def save_collection(coll: Collection, path) -> Path:
    """Write ``coll`` as ``path`` (``.npz``) plus its manifest (``.json``), atomically; returns the ``.npz`` path."""
    path = Path(path).with_suffix(".npz")
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = dict(
        vertices=coll.vertices.astype(np.float32), faces=coll.faces.astype(np.int64),
        operators=coll.operators.astype(np.float32), split=coll.split.astype(str),
        subcollection=coll.subcollection.astype(str), base_vertices=coll.base_basis.mesh.vertices,
        base_evals=coll.base_basis.evals, base_evecs=coll.base_basis.evecs, base_mass=coll.base_basis.mass,
        eval_subset=coll.eval_subset.astype(np.int64), **{f"param_{k}": np.asarray(v) for k, v in coll.params.items()},
    )

    def write_npz(tmp):
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)

    path.with_suffix(".json").unlink(missing_ok=True)  # an old manifest must not vouch for new data
    _atomic_write(path, write_npz)
    manifest = dict(coll.meta, format_version=FORMAT_VERSION, sha256=_sha256(path),
                    shapes={k: list(v.shape) for k, v in arrays.items()})
    _atomic_write(path.with_suffix(".json"), lambda tmp: tmp.write_text(json.dumps(manifest, indent=1, sort_keys=True)))
    return path


def read_collection(path, expected_meta: dict | None = None) -> Collection:
    """Load a collection written by :func:`save_collection`, verifying its manifest and checksum.

    Raises :class:`CollectionError` when the manifest is missing, the checksum or format
    differs, or a key of ``expected_meta`` (e.g. the preset or seed) does not match.
    """
    path = Path(path).with_suffix(".npz")
    fix = f"delete {path} (and its .json) or pass rebuild=True to rebuild it"
    manifest_path = path.with_suffix(".json")
    if not path.is_file():
        raise CollectionError(f"no collection at {path}; build it with opnet.data.load_collection(...).")
    if not manifest_path.is_file():
        raise CollectionError(f"{path} has no manifest, so its build was interrupted; {fix}.")
    try:
        manifest = json.loads(manifest_path.read_text())
    except json.JSONDecodeError:
        raise CollectionError(f"the manifest {manifest_path} is corrupt; {fix}.") from None
    if manifest.get("format_version") != FORMAT_VERSION:
        raise CollectionError(f"{path} has format {manifest.get('format_version')}, this opnet reads {FORMAT_VERSION}; {fix}.")
    for key, value in (expected_meta or {}).items():
        if manifest.get(key) != value:
            raise CollectionError(f"{path} was built with {key}={manifest.get(key)!r}, expected {value!r}; {fix}.")
    if _sha256(path) != manifest.get("sha256"):
        raise CollectionError(f"{path} does not match the checksum in its manifest (corrupt or modified); {fix}.")
    with np.load(path) as z:
        data = {k: z[k] for k in z.files}
    base = Mesh(data.pop("base_vertices"), data["faces"])
    basis = Eigenbasis(base, data.pop("base_evals"), data.pop("base_evecs"), data.pop("base_mass"))
    params = {k[len("param_"):]: data.pop(k) for k in list(data) if k.startswith("param_")}
    meta = {k: v for k, v in manifest.items() if k not in ("sha256", "shapes", "format_version")}
    return Collection(data["vertices"], data["faces"], data["operators"], data["split"],
                      data["subcollection"], basis, data["eval_subset"], params, meta)


def assemble(vertices: np.ndarray, faces: np.ndarray, base_vertices: np.ndarray, split: np.ndarray,
             subcollection: np.ndarray, params: dict, meta: dict, *, k: int = 60, progress: bool | None = None,
             n_eval: int = 5) -> Collection:
    """A :class:`Collection` from shapes in correspondence: computes the base eigenbasis, the operators
    (fast path) and the evaluation subset (``n_eval`` shapes per test sub-collection by furthest-point
    sampling on Hausdorff distance: 10 × 5 = 50 as in the paper)."""
    from .splits import furthest_point_subset

    base = Mesh(base_vertices, faces)
    basis = eigenbasis(base, k)
    operators = shape_differences(basis, vertices, KINDS, progress=progress).astype(np.float32)
    subset = []
    for sc in sorted(set(subcollection[split == "test"])):
        members = np.flatnonzero(subcollection == sc)
        subset.extend(members[furthest_point_subset(vertices[members], n_eval)])
    return Collection(vertices.astype(np.float32), faces, operators, split, subcollection, basis,
                      np.array(sorted(subset), dtype=np.int64), params, dict(meta, k=k))


def load_collection(name: str, preset: str = "quick", root=None, *, resolution: str | None = None, seed: int = 0,
                    rebuild: bool = False, progress: bool | None = None) -> Collection:
    """The collection ``name`` (``"humans"``, ``"heads"`` or ``"hands"``) at ``preset``, built if missing.

    ``preset`` is ``"quick"`` (a few hundred shapes, for tests), ``"default"`` (several thousand, minutes on a
    laptop CPU) or ``"paper"`` (≈17 000 training shapes like the paper's). ``resolution`` (humans only) picks
    the ``"1k"`` (default), ``"2k"`` or ``"5k"``-vertex version of the same shapes. A cached file is reused when its parameters match;
    a corrupt or mismatched one raises :class:`CollectionError` naming the fix (``rebuild=True``).
    """
    from .generators import GENERATORS, GENERATOR_VERSION, PRESETS

    if name not in GENERATORS:
        raise ValueError(f"unknown collection {name!r}; use one of {sorted(GENERATORS)} (or load_folder for your own meshes).")
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; use one of {list(PRESETS)}.")
    generate, resolutions = GENERATORS[name]
    resolution = resolutions[0] if resolution is None else resolution
    if resolution not in resolutions:
        raise ValueError(f"the {name} collection comes in resolutions {list(resolutions)}, not {resolution!r}.")
    root = Path(root) if root is not None else default_root()
    stem = root / f"{name}-{preset}-{resolution}-seed{seed}"
    meta = dict(name=name, preset=preset, resolution=resolution, seed=seed, generator_version=GENERATOR_VERSION)
    if not rebuild and stem.with_suffix(".npz").is_file():
        return read_collection(stem, expected_meta=meta)
    coll = generate(preset=preset, resolution=resolution, seed=seed, meta=meta, progress=progress)
    save_collection(coll, stem)
    return coll


def load_folder(folder, *, base: str | None = None, k: int = 60, progress: bool | None = None) -> Collection:
    """A collection from a folder of your own meshes in correspondence (same faces, any of .ply .obj .off).

    Shapes are read in file-name order; ``base`` names the file used as base shape (default: the first).
    An optional ``splits.csv`` with lines ``filename,split,subcollection`` assigns splits (default: every
    shape ``"train"``, each in its own sub-collection named after its file). Save the result with
    :func:`save_collection`.
    """
    from ..mesh import load_mesh

    folder = Path(folder)
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in (".ply", ".obj", ".off"))
    if not files:
        raise CollectionError(f"no .ply/.obj/.off meshes in {folder}.")
    meshes = []
    for p in files:
        try:
            meshes.append(load_mesh(p))
        except MeshError as exc:
            raise CollectionError(f"{p.name}: {exc}") from None
    for p, m in zip(files, meshes):
        if not np.array_equal(m.faces, meshes[0].faces):
            raise CollectionError(f"{p.name} has other faces than {files[0].name}: the meshes must be in 1-1 correspondence "
                                  "with one shared triangulation.")
    names = [p.name for p in files]
    split = np.full(len(files), "train", dtype=object)
    subcollection = np.array([p.stem for p in files], dtype=object)
    table = folder / "splits.csv"
    if table.is_file():
        for line_no, line in enumerate(table.read_text().splitlines(), 1):
            if not line.strip():
                continue
            fields = [s.strip() for s in line.split(",")]
            if len(fields) != 3 or fields[0] not in names or fields[1] not in {"train", "val", "test", "test_subjects"}:
                raise CollectionError(f"{table}:{line_no}: expected 'filename,split,subcollection' with a known file "
                                      f"and a split in train/val/test/test_subjects, got {line!r}.")
            split[names.index(fields[0])], subcollection[names.index(fields[0])] = fields[1], fields[2]
    base_index = 0 if base is None else names.index(base) if base in names else None
    if base_index is None:
        raise CollectionError(f"base {base!r} is not one of the meshes in {folder}.")
    vertices = np.stack([m.vertices for m in meshes])
    meta = dict(name=folder.name, preset="folder", resolution=f"{vertices.shape[1]}", seed=0,
                generator_version="folder", base=names[base_index])
    return assemble(vertices, meshes[0].faces, vertices[base_index], split.astype(str), subcollection.astype(str),
                    {"filename": np.array(names)}, meta, k=k, progress=progress)
