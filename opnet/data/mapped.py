"""Collections whose operators come through maps from another triangulation: Table 1's "Comp" rows and the
different-discretisation rows of :mod:`opnet.reproduce`.

:func:`mapped_collection` takes a generated humans collection and returns the same shapes whose operators are
those of each shape's 2k- or 5k-vertex version (:func:`~opnet.data.generators.generate_shapes` with
``resolution``), encoded onto the base through a map (:func:`opnet.matching.operators_through_map`):

- ``maps="computed"``: :func:`opnet.matching.compute_map`, which knows nothing of the correspondence (about
  0.6 s per 2k shape, 2.4 s per 5k shape on one core; the shapes are spread over ``n_jobs`` processes);
- ``maps="true"``: the generator's own correspondence (:func:`~opnet.data.generators.resolution_map`): what
  the change of triangulation alone does to the operators.

The vertices stay the collection's (the base's triangulation): they are what a network decodes to and is
measured against. ``params`` gains ``map_error`` ``(N,)`` (metres: the mean distance between where the map
and the true map send each vertex, :meth:`opnet.matching.SurfaceMap.error`), ``map_coverage`` and
``map_orientation`` ``(N,)`` (:meth:`~opnet.matching.SurfaceMap.quality`).

On disk it is a collection like any other (``<source>-<maps><resolution>-<hash>`` under the data root), built
in chunks: each finished chunk of shapes ``start`` to ``stop`` is written atomically as
``<stem>.part-<start>-<stop>.npz``, so an interrupted build continues where it stopped (with the same ``chunk``),
and the parts are removed once the collection is saved.
"""

from __future__ import annotations

import hashlib
import warnings
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._checks import check_int, is_integer
from .._deprecation import renamed_keyword
from .._extras import require
from .._files import atomic_write, remove_stale_tmp
from ..inner_products import channel_digest, get_inner_products, split_channels
from ..shape_difference import KINDS
from . import humans
from .generators import generate_shapes, generated_name, resolution_map, stem_name
from .profiles import PROFILES, profile_of
from .storage import (
    BYTES_PER_SHAPE,
    Collection,
    CollectionError,
    check_root,
    default_root,
    read_collection,
    save_or_warn,
)

__all__ = ["mapped_collection", "labels_collection", "half_mapped", "three_way_mapped", "MAPS", "MAP_K"]

#: How the shapes' other triangulation is mapped onto the base.
MAPS = ("computed", "true")
#: Functions at the end of ZoomOut, by default (:func:`opnet.matching.compute_map`'s).
MAP_K = 100
_FORMAT = 1  # of the parts and of what the stem's hash covers
_FIELDS = ("operators", "map_error", "coverage", "orientation")  # of a part


@renamed_keyword("kinds", "channels")
def mapped_collection(
    collection: Collection,
    resolution: str = "2k",
    maps: str = "computed",
    *,
    indices=None,
    root=None,
    rebuild: bool = False,
    n_jobs: int = -1,
    chunk: int = 32,
    k: int = MAP_K,
    channels=None,
    progress: bool | None = None,
) -> Collection:
    """``collection``'s shapes (or those of ``indices``) with operators through maps from their ``resolution`` mesh.

    Parameters
    ----------
    collection : Collection
        A generated humans collection (:func:`opnet.data.load_collection`), whose base is the 1k mesh (not one of
        :func:`labels_collection`, whose vertices are on another mesh).
    resolution : str
        The other triangulation: one of :data:`opnet.data.humans.RESOLUTIONS` (``"2k"``, ``"5k"``).
    maps : str
        ``"computed"`` or ``"true"`` (see the module docstring).
    indices : array of int, optional
        Only these shapes, in this order (:meth:`Collection.subset`; at least one); default all.
    root : path, optional
        Where it is cached (default :func:`opnet.data.default_root`); reused when it exists.
    rebuild : bool
        Rebuild even if cached.
    n_jobs : int
        Processes computing maps (joblib's convention: ``-1`` all cores, ``-2`` all but one).
    chunk : int
        Shapes per stored part (what an interruption can lose at most, per process); fewer when the shapes would not
        give every process a part (a dozen shapes on 2 cores: two parts of 6, both cores busy).
    k : int
        Functions at the end of ZoomOut (:func:`opnet.matching.compute_map`).
    channels : channels, optional
        The channels to compute through the maps (names or inner products, in order; default :data:`opnet.KINDS`).
        Each one's :meth:`~opnet.InnerProduct.pull_back` carries it onto the base. Other channels are another
        cached collection (the stem's hash covers their digests).
    progress : bool or None
        A progress bar over the shapes (``None``: only when there are more than a chunk).

    Returns
    -------
    Collection
        With ``meta`` gaining ``maps``, ``map_resolution``, ``map_k`` and ``source`` (the source's name).
    """
    _check_source(collection, "mapped collections")
    if resolution not in humans.RESOLUTIONS:
        raise ValueError(f"resolution must be one of {list(humans.RESOLUTIONS)}, got {resolution!r}.")
    if maps not in MAPS:
        raise ValueError(f"maps must be one of {MAPS}, got {maps!r}.")
    check_int("chunk", chunk)
    check_int("k", k)
    if not is_integer(n_jobs) or n_jobs == 0:
        raise ValueError(f"n_jobs must be a non-zero integer (-1: all cores), got {n_jobs!r}.")
    ips = get_inner_products(KINDS if channels is None else split_channels(channels))
    source = collection if indices is None else collection.subset(indices)
    if len(source) == 0:
        raise ValueError("indices is empty: give at least one shape index.")
    m = collection.meta
    stem = Path(root) if root is not None else default_root()
    stem = stem / f"{stem_name(m)}-{maps}{resolution}-{_fingerprint(source, k, ips)}"
    meta = dict(
        source.meta,
        maps=maps,
        map_resolution=resolution,
        map_k=int(k),
        source=f"{m['name']}-{m['preset']}-{m['resolution']}",
    )
    if not rebuild and stem.with_name(stem.name + ".json").is_file():
        out = read_collection(stem, expected_meta=meta)
        out._instances.update((ip.name, ip) for ip in ips)  # the inner products the caller gave, for new shapes
        return out
    check_root(stem.parent, len(source) * BYTES_PER_SHAPE)
    remove_stale_tmp(stem.parent.glob(f".{stem.name}.part-*.tmp-*"))  # parts of killed builds
    if rebuild:
        _remove_parts(stem)
    results = _compute(source, stem, resolution, maps, k, n_jobs, chunk, progress, ips)
    operators, error, coverage, orientation = (np.concatenate(r) for r in zip(*results))
    if len(operators) != len(source):  # the parts must tile the shapes exactly
        raise CollectionError(
            f"the parts of {stem} hold {len(operators)} shapes, not {len(source)}; pass rebuild=True."
        )
    params = dict(source.params, map_error=error, map_coverage=coverage, map_orientation=orientation)
    names = tuple(ip.name for ip in ips)
    out = replace(
        source,
        operators=operators,
        params=params,
        meta=meta,
        channels=names,
        digests=dict(zip(names, map(channel_digest, ips))),
    )
    out._instances.update(zip(names, ips))
    if save_or_warn(out, stem):  # else the parts stay, and the next call assembles them without recomputing
        _remove_parts(stem)
    return out


def _check_source(collection, made: str) -> None:
    """Refuse what :func:`mapped_collection` and :func:`labels_collection` cannot start from: anything but a generated
    collection at its base resolution whose profile has other triangulations, its labels on its own mesh. ``made``
    names what they make, for the message.
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be an opnet.data.Collection, got {type(collection).__name__}.")
    if "labels_resolution" in collection.meta:
        finer = collection.meta["labels_resolution"]
        raise ValueError(
            f"{made} are made from a collection whose vertices are on its base mesh; this one's are on the {finer} "
            "mesh (opnet.data.labels_collection): pass the collection it was made from."
        )
    p = profile_of(generated_name(collection))
    base = collection.meta.get("resolution")
    if not p.computed_maps or base != p.resolutions[0]:
        offered = [name for name, q in PROFILES.items() if q.computed_maps]
        raise ValueError(
            f"{made} are made from a generated collection at its base resolution whose profile has other "
            f"triangulations (computed_maps: {offered}, e.g. the 1k humans, opnet.data.load_collection('humans', "
            f"preset)); this one is the {p.name} at {base!r}."
        )


def labels_collection(collection: Collection, resolution: str = "2k", *, root=None, rebuild: bool = False):
    """``collection``'s shapes with the base's operators as they are, but each shape's vertices and faces those of its
    ``resolution`` mesh: what a network trained with finer labels decodes to (the paper's appendix, the third row of
    its figure of other discretisations: OperatorNet trained on 2k-vertex labels from the 1k base's operators).

    Parameters
    ----------
    collection : Collection
        A generated collection at its base resolution whose profile has other triangulations (the 1k humans).
    resolution : str
        The labels' mesh: one of :data:`opnet.data.humans.RESOLUTIONS` other than the base's.
    root, rebuild
        Where it is cached (default :func:`opnet.data.default_root`), and whether to build it again.

    Returns
    -------
    Collection
        ``vertices`` ``(N, n_resolution, 3)`` in ``collection``'s dtype (metres,
        :func:`~opnet.data.generators.generate_shapes` with ``resolution``), ``faces``
        ``humans.human_faces(resolution)``; ``operators``, splits, ``params`` and the base as ``collection``'s;
        ``meta`` gains ``labels_resolution``. Seconds per hundred shapes to build; the vertices are cached under
        ``root`` (``<collection>-labels<resolution>-<hash>.npy``, written atomically). It is not saved as a
        collection, given new channels or refined (those need the base's mesh): each says so.
    """
    _check_source(collection, "labels on another mesh")
    base = collection.meta["resolution"]
    if resolution not in humans.RESOLUTIONS or resolution == base:
        others = [r for r in humans.RESOLUTIONS if r != base]
        raise ValueError(f"resolution must be one of {others}, got {resolution!r}.")
    from .anny_adapter import model_code_version

    dtype = collection.vertices.dtype
    h = hashlib.sha256(f"labels-{_FORMAT}-{model_code_version()}-{resolution}-{dtype.str}".encode())
    for a in (collection.params["phenotypes"], collection.params["controls"]):  # what the shapes are made from
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(np.ascontiguousarray(a).data)
    root = Path(root) if root is not None else default_root()
    path = root / f"{stem_name(collection.meta)}-labels{resolution}-{h.hexdigest()[:12]}.npy"
    faces = humans.human_faces(resolution)
    shape = (len(collection), int(faces.max()) + 1, 3)
    vertices = None
    if not rebuild and path.is_file():  # written atomically: a whole file or none
        try:
            vertices = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError) as exc:
            raise CollectionError(f"{path} cannot be read ({exc}); delete it or pass rebuild=True.") from None
        if vertices.shape != shape or vertices.dtype != dtype:
            raise CollectionError(
                f"{path} holds {vertices.shape} {vertices.dtype}, not {shape} {dtype}; delete it or pass rebuild=True."
            )
    if vertices is None:
        check_root(root, int(np.prod(shape)) * dtype.itemsize)
        params = collection.params
        vertices = generate_shapes(collection, params["phenotypes"], params["controls"], resolution=resolution)
        vertices = vertices.astype(dtype)
        try:
            atomic_write(path, lambda f: np.save(f, vertices, allow_pickle=False))
        except OSError as exc:  # e.g. the disk filled up meanwhile: the built labels are returned all the same
            warnings.warn(
                f"the labels could not be cached at {path} ({exc}); they will be built again next time.", stacklevel=2
            )
    # the shapes' faces are the labels' mesh (not stored: a Collection on disk holds the base's faces)
    meta = dict(collection.meta, labels_resolution=resolution)
    out = replace(collection, vertices=vertices, faces=faces, meta=meta)
    out._instances.update(collection._instances)  # the inner products given to the source (replace drops them)
    return out


def half_mapped(collection: Collection, mapped: Collection) -> Collection:
    """``mapped`` (:func:`mapped_collection` of ``collection``) with every other training shape taken with its exact
    operators from ``collection`` instead: a network trained on it sees both kinds of operators, as many shapes as
    either alone. The held-out splits keep the mapped operators, so it is evaluated like ``mapped``.

    Parameters
    ----------
    collection : Collection
        The shapes with their exact operators.
    mapped : Collection
        The same shapes, in the same order, with operators through maps.

    Returns
    -------
    Collection
        The held-out shapes and the even training shapes of ``mapped``, then the odd training shapes of
        ``collection`` (:meth:`Collection.with_training_from`).
    """
    _check_same_shapes(collection, mapped)
    train = collection.indices("train")
    kept = np.sort(np.r_[np.flatnonzero(collection.split != "train"), train[::2]])
    return mapped.subset(kept).with_training_from(collection.subset(train[1::2]))


def three_way_mapped(
    collection: Collection, mapped: Collection, resolution: str = "5k", *, root=None, n_jobs: int = -1, progress=None
) -> Collection:
    """``mapped`` (:func:`mapped_collection` of ``collection``, e.g. from the 2k meshes) with a third of the training
    shapes taken with their exact operators from ``collection`` and a sixth through maps computed from their
    ``resolution`` mesh instead (computed here, cached like :func:`mapped_collection`'s: seconds per shape): a network
    trained on it sees three kinds of operators, as many shapes as any alone. The held-out splits keep ``mapped``'s
    operators, so it is evaluated like ``mapped``.

    Returns
    -------
    Collection
        The held-out shapes and half the training shapes of ``mapped``, then every third training shape (from the
        second) of ``collection``, then every sixth (from the third) through the ``resolution`` maps
        (:meth:`Collection.with_training_from`).
    """
    _check_same_shapes(collection, mapped)
    train = collection.indices("train")
    exact, fine = train[1::3], train[2::6]
    kept = np.setdiff1d(np.arange(len(collection)), np.r_[exact, fine])
    finer = mapped_collection(
        collection, resolution, "computed", indices=fine, root=root, n_jobs=n_jobs, progress=progress
    )
    return mapped.subset(kept).with_training_from(collection.subset(exact), finer)


def _check_same_shapes(collection: Collection, mapped: Collection) -> None:
    """Refuse a ``mapped`` that does not hold ``collection``'s shapes in its order."""
    if len(mapped) != len(collection) or not np.array_equal(mapped.vertices, collection.vertices):
        raise ValueError(
            "mapped must hold collection's shapes in its order (opnet.data.mapped_collection(collection, ...))."
        )


def _fingerprint(source: Collection, k: int, ips) -> str:
    """What the operators depend on: the shapes' generator parameters, the base, the versions of the map's code
    (:data:`opnet.matching.MAP_VERSION`, pyFM's), of the 2k/5k models'
    (:func:`~opnet.data.anny_adapter.model_code_version`), ``k`` and, for channels other than :data:`opnet.KINDS`,
    their names and digests; 12 hex digits.
    """
    from importlib.metadata import version

    from ..matching import MAP_VERSION
    from .anny_adapter import model_code_version

    h = hashlib.sha256(f"{_FORMAT}-{MAP_VERSION}-{version('pyfmaps')}-{model_code_version()}-{k}".encode())
    for a in (source.params["phenotypes"], source.params["controls"], source.base_basis.evecs):
        h.update(np.ascontiguousarray(a).data)
    if tuple(ip.name for ip in ips) != KINDS:  # the paper's three keep the stems cached before channels were data
        h.update(repr([(ip.name, channel_digest(ip)) for ip in ips]).encode())
    return h.hexdigest()[:12]


def _remove_parts(stem: Path) -> None:
    for part in stem.parent.glob(f"{stem.name}.part-*.npz"):
        part.unlink(missing_ok=True)  # a concurrent build of the same stem may have removed it


def _compute(
    source: Collection, stem: Path, resolution: str, maps: str, k: int, n_jobs: int, chunk: int, progress, ips
):
    """Per chunk of shapes ``(operators, map_error, coverage, orientation)``, read from finished parts or computed
    (in ``n_jobs`` processes) and stored as parts.
    """
    joblib = require("joblib", "opnet.data.mapped_collection")
    from tqdm.auto import tqdm

    from ..spectral import eigenbasis

    chunk = _chunk_size(len(source), chunk, joblib.effective_n_jobs(n_jobs))
    starts = range(0, len(source), chunk)
    paths = {s: stem.with_name(f"{stem.name}.part-{s:07d}-{min(s + chunk, len(source)):07d}.npz") for s in starts}
    done = {}
    for s, path in paths.items():
        if path.is_file():
            try:
                with np.load(path) as z:
                    done[s] = tuple(z[key] for key in _FIELDS)
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
                raise CollectionError(f"{path} is unreadable ({exc}); delete it or pass rebuild=True.") from None
    todo = [s for s in starts if s not in done]
    bar = tqdm(
        total=len(source),
        initial=sum(len(r[0]) for r in done.values()),
        unit="shape",
        desc=f"{maps} maps from {resolution}",
        disable=progress is False or (progress is None and len(todo) < 2),
    )
    true_to_base = resolution_map(source, resolution)
    faces = humans.human_faces(resolution)
    spectrum = eigenbasis(source.base_basis.mesh, k) if maps == "computed" else None  # the base's, once

    def task(s):
        sl = slice(s, s + chunk)
        vertices = generate_shapes(
            source, source.params["phenotypes"][sl], source.params["controls"][sl], resolution=resolution
        )
        return joblib.delayed(_map_chunk)(source.base_basis, spectrum, vertices, faces, true_to_base, ips)

    with joblib.Parallel(n_jobs=n_jobs, return_as="generator") as parallel:
        for s, result in zip(todo, parallel(task(s) for s in todo)):
            atomic_write(paths[s], lambda f, r=result: np.savez(f, **dict(zip(_FIELDS, r))))
            done[s] = result
            bar.update(len(result[0]))
    bar.close()
    return [done[s] for s in starts]


def _chunk_size(n_shapes: int, chunk: int, workers: int) -> int:
    """Shapes per part: ``chunk``, or fewer where ``n_shapes`` would leave some of the ``workers`` processes idle."""
    return max(1, min(chunk, -(-n_shapes // workers)))


def _map_chunk(base_basis, spectrum, vertices, faces, true_to_base, ips):
    """Operators ``(c, len(ips), k0, k0)`` float32, map errors (metres), coverage and orientation ``(c,)`` of ``c``
    shapes ``vertices`` ``(c, n, 3)`` on ``faces``: through computed maps with the base's ``spectrum`` (its first ``k``
    eigenpairs), or through the true map ``true_to_base`` when ``spectrum`` is None.
    """
    from ..matching import SurfaceMap, compute_map, operators_through_map
    from ..mesh import Mesh

    if spectrum is not None:  # the same base mesh object as base_basis's, whatever pickling did to the two
        spectrum = replace(spectrum, mesh=base_basis.mesh)
    scale = np.sqrt(base_basis.mesh.area)
    maps, stats = [], []
    for v in vertices:
        mesh = Mesh(v, faces)
        true = SurfaceMap(base_basis, mesh, true_to_base)
        sm = true if spectrum is None else compute_map(base_basis, mesh, k=spectrum.k, base_spectrum=spectrum)
        q = sm.quality()
        maps.append(sm)
        stats.append((sm.error(true).mean() * scale, q["coverage"], q["orientation"]))
    return (operators_through_map(maps, ips).astype(np.float32), *(np.array(x) for x in zip(*stats)))
