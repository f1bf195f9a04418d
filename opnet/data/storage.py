"""Shape collections in memory (:class:`Collection`) and on disk: one documented format, written atomically,
checked on load.

A collection is a set of meshes in 1-1 correspondence (shared faces) with, for every
shape, its three shape differences against a fixed base shape (fast path, ``k`` = 60 on
the base by default), its split label, its sub-collection, its subject and the parameters it was
generated from. On disk, a collection stored under the path ``stem`` is two files:

``stem.<sha>.npz`` (``<sha>``: the first 12 hex digits of its SHA-256)
    ``vertices`` (N, n, 3) float32 (metres for the body models), ``faces`` (m, 3) int64,
    ``operators`` (N, C, k, k) float32 (channels: the manifest's ``channels``, by default area, conformal,
    extrinsic),
    ``split`` (N,) str, ``subcollection`` (N,) str, ``subject`` (N,) str, ``base_vertices`` (n, 3) float64,
    ``base_evals`` (k,), ``base_evecs`` (n, k), ``base_mass`` (n,) float64 (the base
    eigenbasis every consumer must use), ``eval_subset`` (indices of the evaluation
    subset), and ``param_<name>`` arrays (N, ...) of per-shape parameters.
``stem.json``
    the manifest: format and generator versions, name, preset, resolution, seed, k, the
    shapes of the arrays, the operators' channels (``channels``: names in order; ``channel_digests``: each one's
    :func:`opnet.channel_digest`), the data file's name and its full SHA-256.

Channels added later (:meth:`Collection.with_channels`) are cached beside these two files, one file per channel
(:mod:`opnet.data.channels`); a collection written before channels were recorded holds :data:`opnet.KINDS`.

Format 2 (before the ``subject`` array) is read too: each shape's subject is then its sub-collection's name up to
the ``/`` (a folder collection's: the whole sub-collection), as the generators named them.

The manifest is the commit point: the data is written under a temporary name and renamed,
then the manifest is written under a temporary name and renamed over the old one, and only
then are older data files removed. A reader therefore sees either the previous complete
collection or the new one, never a half-written file, and an interrupted first build
leaves nothing that loads (:class:`CollectionError` says what to do).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._deprecation import renamed_keyword, warn_renamed
from .._files import remove_stale_tmp, tmp_name
from ..inner_products import (
    INNER_PRODUCTS,
    ChannelError,
    channel_digest,
    channel_identity,
    get_inner_product,
    split_channels,
)
from ..mesh import Mesh
from ..shape_difference import KINDS
from ..spectral import Eigenbasis
from . import channels as _channels

__all__ = [
    "Collection",
    "CollectionError",
    "save_collection",
    "read_collection",
    "default_root",
    "FORMAT_VERSION",
    "SPLITS",
]

#: The on-disk format's version, stored in each manifest (3: the per-shape ``subject``).
FORMAT_VERSION = 3
#: The splits, as stored in a collection's ``split`` array.
SPLITS = ("train", "val", "test", "test_subjects")


class CollectionError(RuntimeError):
    """A collection file that is missing, corrupt or built with other parameters; the message says how to rebuild."""


@dataclass(eq=False)
class Collection:
    """Shapes in correspondence with their shape differences (see the module docstring for the fields).

    ``subcollection`` (N,) names each shape's sequence (for a generated collection ``"subject03/walk"``: one
    subject's motion), the unit that splits hold out whole; ``subject`` (N,) names the person (``"subject03"``),
    the unit of the ``test_subjects`` split. For a folder of your own meshes both come from ``splits.csv``.

    ``channels``: the names of the operators' channels, in the order of their second axis (default
    :data:`opnet.KINDS`); ``digests``: each one's :func:`opnet.channel_digest`. The old name ``kinds`` (the field
    :attr:`kinds`, ``Collection(..., kinds=...)``, :meth:`with_kinds`) still works and warns once
    (``DeprecationWarning``).
    """

    vertices: np.ndarray
    faces: np.ndarray
    operators: np.ndarray
    split: np.ndarray
    subcollection: np.ndarray
    subject: np.ndarray
    base_basis: Eigenbasis
    eval_subset: np.ndarray
    params: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    channels: tuple = KINDS
    digests: dict = field(default_factory=dict)
    # where it is stored, (stem, data SHA-256), so that channels added later are cached beside it
    _stored: tuple | None = field(default=None, init=False, repr=False)
    # the inner products given to with_channels this session, by name (what apps and refinement recompute with)
    _instances: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self):
        if not isinstance(self.base_basis, Eigenbasis):
            raise TypeError(
                f"base_basis must be an opnet.Eigenbasis, got {type(self.base_basis).__name__} (Collection's fields "
                "are vertices, faces, operators, split, subcollection, subject, base_basis, ...: pass them by name)."
            )
        lengths = {f: len(getattr(self, f)) for f in ("vertices", "operators", "split", "subcollection", "subject")}
        if len(set(lengths.values())) != 1:
            raise ValueError(f"a collection's per-shape arrays must have one length each, got {lengths}.")
        if isinstance(self.channels, str) or not all(isinstance(c, str) for c in self.channels):
            raise TypeError(f"channels must be a tuple of channel names, got {self.channels!r}.")
        self.channels = tuple(self.channels)
        if len(set(self.channels)) != len(self.channels) or np.ndim(self.operators) != 4:
            raise ValueError(
                f"channels must name each channel once, and operators be (N, C, k, k); got {self.channels}."
            )
        if self.operators.shape[1] != len(self.channels):
            raise ValueError(
                f"operators hold {self.operators.shape[1]} channels (shape {self.operators.shape}) but channels "
                f"names {len(self.channels)}: {self.channels}."
            )
        recorded = dict(self.digests)
        self.digests = {c: recorded.get(c) or _builtin_digest(c) for c in self.channels}

    @property
    def kinds(self) -> tuple:
        """Deprecated name of :attr:`channels` (warns once)."""
        warn_renamed("Collection.kinds", "Collection.channels")
        return self.channels

    def __len__(self) -> int:
        return len(self.vertices)

    def indices(self, split: str) -> np.ndarray:
        """Indices of the shapes of one split (``"train"``, ``"val"``, ``"test"``, ``"test_subjects"``)."""
        if split not in SPLITS:
            raise ValueError(f"unknown split {split!r}; use one of {SPLITS}.")
        return np.flatnonzero(self.split == split)

    def sequence(self, subject: str, motion: str | None = None) -> np.ndarray:
        """Indices of one subject's shapes, in stored (frame) order; with ``motion``, only those of one of its
        sub-collections, named in full or, in a generated collection, by its motion (``"walk"`` for
        ``"subject03/walk"``).
        """
        mask = self.subject == subject
        if not mask.any():
            raise ValueError(f"no subject {subject!r} in this collection; it has {self.subjects()}.")
        if motion is not None:
            mask &= np.isin(self.subcollection, [motion, f"{subject}/{motion}"])
            if not mask.any():
                own = sorted(set(self.subcollection[self.subject == subject]))
                raise ValueError(f"subject {subject!r} has no sequence {motion!r}; it has {own}.")
        return np.flatnonzero(mask)

    def subjects(self, split: str | None = None) -> list[str]:
        """The subjects (sorted), all or those with shapes in one split."""
        idx = slice(None) if split is None else self.indices(split)
        return sorted(set(self.subject[idx].tolist()))

    def mesh(self, i: int) -> Mesh:
        """Shape ``i`` as a :class:`opnet.Mesh` (float64)."""
        return Mesh(self.vertices[i].astype(np.float64), self.faces)

    def subset(self, indices) -> Collection:
        """Shapes ``indices`` (distinct, in that order) as a collection of their own: vertices, operators, splits,
        sub-collections, subjects and parameters are taken; the evaluation subset keeps those of its shapes that are.
        """
        idx = np.asarray(indices)
        if idx.ndim != 1 or (idx.size and idx.dtype.kind not in "iu"):
            hint = " (for a boolean mask, pass np.flatnonzero(mask))" if idx.dtype == bool else ""
            raise ValueError(
                f"indices must be a 1-D array of shape indices{hint}, got {idx.dtype} array of shape {idx.shape}."
            )
        idx = idx.astype(np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= len(self)):
            raise ValueError(f"indices must lie in [0, {len(self) - 1}], got [{idx.min()}, {idx.max()}].")
        if len(np.unique(idx)) != len(idx):
            raise ValueError("indices has repeated shapes; give each shape once (np.unique(indices)).")
        position = {int(i): j for j, i in enumerate(idx)}
        eval_subset = np.sort([position[i] for i in self.eval_subset.tolist() if i in position]).astype(np.int64)
        out = Collection(
            self.vertices[idx],
            self.faces,
            self.operators[idx],
            self.split[idx],
            self.subcollection[idx],
            self.subject[idx],
            self.base_basis,
            eval_subset,
            {k: v[idx] for k, v in self.params.items()},
            dict(self.meta),
            self.channels,
            dict(self.digests),
        )
        out._instances.update(self._instances)
        return out

    def with_training_from(self, *others) -> Collection:
        """A collection of these shapes and the ``train`` shapes of ``others``, added to its ``train`` split (at
        the end), each with its own operators: the same shapes encoded otherwise (e.g. through computed maps of other
        triangulations, :func:`opnet.data.mapped_collection`), or more shapes. The held-out splits and the evaluation
        subset are this collection's. ``others`` must have the same base shape, basis, faces and channels (names and
        digests). The parameters (``params``) that every part holds are concatenated; the others are dropped (e.g. a
        mapped collection's ``map_error``).

        Returns
        -------
        Collection
            ``len(self)`` plus the others' training shapes; its ``meta`` lists theirs under ``"training_from"``.
        """
        parts = [self]
        for other in others:
            if not isinstance(other, Collection):
                raise TypeError(f"others must be opnet.data.Collection objects, got {type(other).__name__}.")
            same = (
                other.vertices.shape[1:] == self.vertices.shape[1:]
                and other.channels == self.channels
                and other.digests == self.digests
                and other.base_basis.k == self.base_basis.k
                and np.array_equal(other.base_basis.mesh.vertices, self.base_basis.mesh.vertices)
                and np.array_equal(other.base_basis.evecs, self.base_basis.evecs)
                and np.array_equal(other.faces, self.faces)
            )
            if not same:
                raise ValueError(
                    f"{other!r} cannot lend its training shapes to {self!r}: they need the same base shape, basis "
                    "size and eigenvectors, faces and channels (with_channels gives them the same channels)."
                )
            parts.append(other.subset(other.indices("train")))
        if len(parts) == 1:
            return self
        params = {
            k: np.concatenate([p.params[k] for p in parts]) for k in self.params if all(k in p.params for p in parts)
        }
        out = Collection(
            np.concatenate([p.vertices for p in parts]),
            self.faces,
            np.concatenate([p.operators for p in parts]),
            np.concatenate([p.split for p in parts]),
            np.concatenate([p.subcollection for p in parts]),
            np.concatenate([p.subject for p in parts]),
            self.base_basis,
            self.eval_subset,
            params,
            dict(self.meta, training_from=[dict(p.meta) for p in parts[1:]]),
            self.channels,
            dict(self.digests),
        )
        out._instances.update(self._instances)
        return out

    # ------------------------------------------------------------------------------------------------------
    # channels

    def channel_names(self, channels) -> tuple[str, ...]:
        """The names of ``channels`` asked of this collection, in that order: names it holds, instances (their
        recorded implementation checked), ``"area,extrinsic"``, a short name of :data:`opnet.CHANNEL_SETS` or
        ``"module:Class"``. A channel it does not hold raises a ``ChannelError`` naming :meth:`with_channels`.
        """
        return tuple(name for name, _ in self._resolve(channels))

    def channel_indices(self, channels) -> list[int]:
        """Positions of ``channels`` (as in :meth:`channel_names`) on the second axis of :attr:`operators`."""
        return [self.channels.index(name) for name in self.channel_names(channels)]

    def operators_for(self, channels) -> np.ndarray:
        """The operators ``(N, len(channels), k, k)`` float32 of ``channels`` (as in :meth:`channel_names`), in the
        order asked (a copy unless they are all of :attr:`operators`, in order).
        """
        idx = self.channel_indices(channels)
        return self.operators if idx == list(range(len(self.channels))) else self.operators[:, idx]

    def inner_products(self, channels=None) -> list:
        """The inner products of ``channels`` (default all of :attr:`channels`): what the operators of a new shape are
        computed with (the algebra of :mod:`opnet.apps`, refinement). A channel of your own that was read back
        from disk is known once you pass its instance (or register it, :func:`opnet.register_inner_product`).
        """
        out = []
        for name, ip in self._resolve(self.channels if channels is None else channels):
            if ip is None:
                raise ChannelError(
                    f"the collection holds the operators of channel {name!r} but not its inner product (it was read "
                    f"from disk): pass the instance (collection.with_channels([..., MyIP()]) or channels=[MyIP()]) or "
                    "opnet.register_inner_product(MyIP()) to compute it for new shapes."
                )
            out.append(ip)
        return out

    def identities(self, channels=None) -> list[dict]:
        """``[{"name", "digest", "spec"}]`` of ``channels`` (default all of :attr:`channels`): what a run records of its
        input (``spec``: ``"module:Class"`` when the inner product is known here and importable, else ``None``).
        """
        out = []
        for name, ip in self._resolve(self.channels if channels is None else channels):
            spec = None if ip is None else channel_identity(ip)["spec"]
            out.append({"name": name, "digest": self.digests.get(name), "spec": spec})
        return out

    def _resolve(self, channels) -> list:
        return _channels.resolve(channels, self.channels, self.digests, self._instances)

    def with_channels(
        self, channels, *, recompute: bool = False, n_jobs: int | None = None, progress=None
    ) -> Collection:
        """A copy of this collection with the channels ``channels`` (names, instances, classes, ``"module:Class"``,
        ``"area,extrinsic"`` or a short name of :data:`opnet.CHANNEL_SETS`), in that order: the ones it holds are
        kept, the others computed for every shape (fast path, ``project_batch`` where the inner product has one, else
        shape by shape in ``n_jobs`` processes, with a progress bar).

        A stored collection caches each new channel beside it (one file per channel, keyed by the channel's digest:
        :mod:`opnet.data.channels`), so asking again reads it back and nothing of the collection is rewritten.
        ``recompute=True`` computes the channels given as inner products (instances, classes, ``"module:Class"``)
        again, even where it holds one of that name or a cache file has them (e.g. after editing a helper the class
        calls); names it holds are kept. A channel that is not invariant to rigid motions warns.

        Returns a new :class:`Collection` whose :attr:`channels` are ``channels`` and :attr:`operators`
        ``(N, len(channels), k, k)``; the vertices and splits are shared with this one.
        """
        items = split_channels(channels)
        if not items:
            raise ChannelError("channels is empty: ask for at least one channel (e.g. ['area', MyIP()]).")
        columns, names, digests, instances = [], [], {}, dict(self._instances)
        for item in items:
            held = isinstance(item, str) and item in self.channels  # a name it holds: kept as it is
            if held:
                ((name, ip),) = self._resolve([item])
            else:
                ip = get_inner_product(item)
                name = ip.name
                if name in self.channels and not recompute:
                    self._resolve([ip])  # refuses another implementation of a channel it holds
            if name in names:
                raise ChannelError(f"channels names the channel {name!r} twice; give each once.")
            if name in self.channels and (held or not recompute):
                columns.append(self.operators[:, self.channels.index(name)])
                digests[name] = self.digests.get(name)
            else:
                columns.append(self._compute_channel(ip, n_jobs=n_jobs, progress=progress, cached=not recompute))
                digests[name] = channel_digest(ip)
            if ip is not None:
                instances[name] = ip
            names.append(name)
        out = Collection(
            self.vertices,
            self.faces,
            np.stack(columns, axis=1),
            self.split,
            self.subcollection,
            self.subject,
            self.base_basis,
            self.eval_subset,
            self.params,
            dict(self.meta),
            tuple(names),
            digests,
        )
        out._stored, out._instances = self._stored, instances
        return out

    def with_kinds(self, kinds, **options) -> Collection:
        """Deprecated name of :meth:`with_channels` (warns once)."""
        warn_renamed("Collection.with_kinds", "Collection.with_channels")
        return self.with_channels(kinds, **options)

    def _compute_channel(self, ip, *, n_jobs, progress, cached: bool = True) -> np.ndarray:
        """One channel's operators ``(N, k, k)`` for every shape: read from the cache beside the stored collection
        when there, else computed (and cached).
        """
        if "labels_resolution" in self.meta:
            raise ChannelError(
                f"this collection's vertices are its shapes on the {self.meta['labels_resolution']} mesh "
                f"(opnet.data.labels_collection), not the base's; add channel {ip.name!r} to the source collection, "
                "then call labels_collection on it."
            )
        if "maps" in self.meta:
            raise ChannelError(
                f"this collection's operators come through maps from its shapes' {self.meta.get('map_resolution')} "
                f"meshes; compute channel {ip.name!r} through the same maps: opnet.data.mapped_collection(source, "
                f"..., channels=[..., {type(ip).__name__}()])."
            )
        digest = channel_digest(ip)
        shape = (len(self), self.base_basis.k, self.base_basis.k)
        path = None if self._stored is None else _channels.cache_path(self._stored[0], ip.name, digest, self._stored[1])
        if path is not None and cached:
            stored = _channels.read_cached(path, ip.name, digest, shape)
            if stored is not None:
                return stored
        if ip.name not in INNER_PRODUCTS:
            _channels.warn_if_not_rigid(ip, self.base_basis)
        operators = _channels.compute_operators(ip, self.base_basis, self.vertices, n_jobs=n_jobs, progress=progress)
        if path is not None:
            _channels.write_cached(path, ip.name, digest, operators)
        return operators

    def __repr__(self) -> str:
        counts = {s: int(np.sum(self.split == s)) for s in SPLITS}
        return (
            f"Collection({self.meta.get('name', '?')!r}, preset={self.meta.get('preset')!r}, shapes={len(self)}, "
            f"vertices={self.vertices.shape[1]}, k={self.base_basis.k}, channels={self.channels}, splits={counts})"
        )


# ``Collection(..., kinds=...)``: the field's old name, still taken (deprecated)
Collection.__init__ = renamed_keyword("kinds", "channels", where="Collection")(Collection.__init__)


def _builtin_digest(name: str) -> str | None:
    """The digest of a built-in channel (what a collection that recorded none holds), ``None`` for another name."""
    return channel_digest(INNER_PRODUCTS[name]) if name in INNER_PRODUCTS else None


def default_root() -> Path:
    """Where collections are cached: ``$OPNET_DATA_DIR`` or ``~/.cache/opnet``."""
    return Path(os.environ.get("OPNET_DATA_DIR", Path.home() / ".cache" / "opnet"))


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 22), b""):
            h.update(chunk)
    return h.hexdigest()


def _stem(path) -> Path:
    path = Path(path)
    return path.with_name(path.name[: -len(".json")]) if path.name.endswith(".json") else path


def _data_files(stem: Path) -> list[Path]:
    pattern = _data_name(stem)
    return [p for p in stem.parent.glob(stem.name + ".*.npz") if pattern.fullmatch(p.name)]


def _data_name(stem: Path) -> re.Pattern:
    """The name of a data file of the collection stored under ``stem``: ``<stem>.<12 hex digits>.npz``."""
    return re.compile(re.escape(stem.name) + r"\.[0-9a-f]{12}\.npz")


def _tmp_files(stem: Path) -> list[Path]:
    return list(stem.parent.glob(f".{stem.name}.tmp-*"))


def save_collection(coll: Collection, path) -> Path:
    """Write ``coll`` under the path ``path`` (data + manifest, see the module docstring); returns the manifest path."""
    if "labels_resolution" in coll.meta:
        raise ValueError(
            f"a collection whose vertices are on the {coll.meta['labels_resolution']} mesh (opnet.data."
            "labels_collection) is not saved: save its source, and call labels_collection again (it caches itself)."
        )
    stem = _stem(path)
    stem.parent.mkdir(parents=True, exist_ok=True)
    arrays = dict(
        vertices=coll.vertices.astype(np.float32),
        faces=coll.faces.astype(np.int64),
        operators=coll.operators.astype(np.float32),
        split=coll.split.astype(str),
        subcollection=coll.subcollection.astype(str),
        subject=coll.subject.astype(str),
        base_vertices=coll.base_basis.mesh.vertices,
        base_evals=coll.base_basis.evals,
        base_evecs=coll.base_basis.evecs,
        base_mass=coll.base_basis.mass,
        eval_subset=coll.eval_subset.astype(np.int64),
        **{f"param_{k}": np.asarray(v) for k, v in coll.params.items()},
    )
    for key, value in arrays.items():
        if value.dtype == object:
            raise TypeError(f"{key} has dtype object, which cannot be stored safely; convert it to str or numbers.")
    remove_stale_tmp(_tmp_files(stem))
    tmp, tmp_manifest = tmp_name(stem, ".npz"), tmp_name(stem, ".json")
    try:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
        digest = _sha256(tmp)
        data = stem.with_name(f"{stem.name}.{digest[:12]}.npz")
        os.replace(tmp, data)
        manifest = dict(
            coll.meta,
            format_version=FORMAT_VERSION,
            data=data.name,
            sha256=digest,
            shapes={k: list(v.shape) for k, v in arrays.items()},
            channels=list(coll.channels),  # the order of the operators' second axis
            channel_digests={c: coll.digests.get(c) for c in coll.channels},
        )
        tmp_manifest.write_text(json.dumps(manifest, indent=1, sort_keys=True, default=_json_scalar))
        os.replace(tmp_manifest, stem.with_name(stem.name + ".json"))  # the commit point
    finally:
        tmp.unlink(missing_ok=True)
        tmp_manifest.unlink(missing_ok=True)
    for old in _data_files(stem):
        if old != data:
            old.unlink(missing_ok=True)
    for old in stem.parent.glob(f"{stem.name}.channel.*.npz"):  # channels cached for an earlier build
        if not old.name.endswith(f".{digest[:12]}.npz"):
            old.unlink(missing_ok=True)
    coll._stored = (stem, digest)
    return stem.with_name(stem.name + ".json")


def _json_scalar(value):
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def read_collection(path, expected_meta: dict | None = None) -> Collection:
    """Load the collection stored under ``path`` (the stem or its ``.json``), verifying manifest and checksum.

    Raises :class:`CollectionError` when it is missing or was interrupted, when the checksum or format
    differs, or when a key of ``expected_meta`` does not match the manifest.
    """
    stem = _stem(path)
    manifest_path = stem.with_name(stem.name + ".json")
    fix = f"delete {stem}.* or pass rebuild=True to rebuild it"
    for attempt in range(2):  # a concurrent save may replace the data between reading manifest and data
        if not manifest_path.is_file():
            if _data_files(stem) or _tmp_files(stem):
                raise CollectionError(f"the build of {stem} was interrupted (no manifest); {fix}.")
            raise CollectionError(f"no collection at {stem}; build it with opnet.data.load_collection(...).")
        try:
            manifest = json.loads(manifest_path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise CollectionError(f"the manifest {manifest_path} is corrupt; {fix}.") from None
        if not isinstance(manifest, dict) or "data" not in manifest:
            raise CollectionError(f"the manifest {manifest_path} is not an opnet manifest; {fix}.")
        if manifest.get("format_version") not in (2, FORMAT_VERSION):  # 2: no subject array, derived below
            raise CollectionError(
                f"{stem} has format {manifest.get('format_version')}, this opnet reads 2 and {FORMAT_VERSION}; "
                "make it again with the function that made it (load_collection(..., rebuild=True), "
                "mapped_collection(..., rebuild=True), or load_folder and save_collection)."
            )
        for key, value in (expected_meta or {}).items():
            if manifest.get(key) != value:
                raise CollectionError(f"{stem} was built with {key}={manifest.get(key)!r}, expected {value!r}; {fix}.")
        entry = manifest["data"]
        if not isinstance(entry, str) or not _data_name(stem).fullmatch(entry):
            raise CollectionError(
                f"the manifest {manifest_path} names {entry!r} as its data file, not a file "
                f"'{stem.name}.<12 hex digits>.npz' beside it; {fix}."
            )
        data_path = stem.with_name(entry)
        if not data_path.is_file():
            if attempt == 0:
                continue
            raise CollectionError(f"{data_path.name}, named by the manifest, is missing; {fix}.")
        if _sha256(data_path) != manifest.get("sha256"):
            raise CollectionError(
                f"{data_path} does not match the checksum in its manifest (corrupt or modified); {fix}."
            )
        break
    try:  # the checksum matches, yet the contents may have been damaged before it was (re)computed
        with np.load(data_path) as z:
            data = {k: z[k] for k in z.files}
        shapes = {k: list(v.shape) for k, v in data.items()}
        if shapes != manifest.get("shapes"):
            raise ValueError(f"its arrays {shapes} are not those of the manifest {manifest.get('shapes')}")
        base = Mesh(data.pop("base_vertices"), data["faces"])
        basis = Eigenbasis(base, data.pop("base_evals"), data.pop("base_evecs"), data.pop("base_mass"))
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise CollectionError(
            f"{data_path} matches its checksum but cannot be read as a collection "
            f"({type(exc).__name__}: {str(exc)[:200]}); {fix}."
        ) from None
    params = {k[len("param_") :]: data.pop(k) for k in list(data) if k.startswith("param_")}
    channels = manifest.get("channels", list(KINDS))  # written before channels were recorded: KINDS
    if (
        not isinstance(channels, list)
        or len(channels) != data["operators"].shape[1]
        or len(set(channels)) != len(channels)
    ):
        raise CollectionError(
            f"the manifest {manifest_path} names the channels {channels!r} for operators of shape "
            f"{data['operators'].shape}; {fix}."
        )
    if "subject" not in data:  # format 2: a generated collection names its sequences "<subject>/<motion>"
        sub = data["subcollection"]
        data["subject"] = sub if manifest.get("preset") == "folder" else np.array([s.split("/")[0] for s in sub])
    skip = ("sha256", "shapes", "format_version", "data", "channels", "channel_digests")
    meta = {k: v for k, v in manifest.items() if k not in skip}
    coll = Collection(
        data["vertices"],
        data["faces"],
        data["operators"],
        data["split"],
        data["subcollection"],
        data["subject"],
        basis,
        data["eval_subset"],
        params,
        meta,
        tuple(channels),
        manifest.get("channel_digests") or {},
    )
    coll._stored = (stem, manifest["sha256"])
    return coll


# Stored bytes per generated shape, at most: a 5k-vertex body (60 kB) and its three 60 × 60 operators (43 kB).
BYTES_PER_SHAPE = 120_000


def check_root(root: Path, needed: int) -> None:
    """Refuse a data root that cannot hold ``needed`` bytes of new files, before anything is built: a file, a
    folder that cannot be created or written, or a disk with less free space (``CollectionError``).
    """
    fix = "pass root= a writable folder or set OPNET_DATA_DIR"
    try:
        root.mkdir(parents=True, exist_ok=True)
        probe = tmp_name(root / "write-check")
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise CollectionError(
            f"the data root {root} is not a writable folder ({exc.strerror or exc}); {fix}."
        ) from None
    free = shutil.disk_usage(root).free
    if free < needed:
        raise CollectionError(
            f"the data root {root} has {free / 1e6:.0f} MB free, and this collection needs about "
            f"{needed / 1e6:.0f} MB; free some space, or {fix}."
        )


def save_or_warn(coll: Collection, stem: Path) -> bool:
    """Save a freshly built collection; when that fails (e.g. the disk filled up meanwhile), warn instead of
    raising, so that the minutes of building are not lost: the caller returns it uncached. Whether it was saved.
    """
    try:
        save_collection(coll, stem)
    except OSError as exc:
        warnings.warn(
            f"the collection could not be saved to {stem} ({exc}); it is returned but not cached, so it "
            "will be built again next time.",
            stacklevel=3,
        )
        return False
    return True
