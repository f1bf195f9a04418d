"""A collection's channels as data: which operators it holds (names and implementation digests), how a channel's
operators are computed for every shape, and where they are cached.

A stored collection keeps the channels it was built with in its own data file. A channel added later with
:meth:`~opnet.data.Collection.with_channels` is cached beside it, one file per channel::

    <stem>.channel.<name>.<digest>.<data>.npz    operators (N, k, k) float32, and its identity

``<name>`` is the channel's name made safe for a file name, ``<digest>`` its :func:`opnet.channel_digest` (16 hex
digits), ``<data>`` the first 12 hex digits of the collection's data checksum: a channel computed by another
implementation, or for another build of the collection, is another file and is never read for this one. The file
is written atomically (a temporary name, then a rename), so an interrupted computation leaves nothing that loads,
and adding a channel never rewrites the collection.
"""

from __future__ import annotations

import json
import re
from functools import partial
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from .._checks import warn_user
from .._files import atomic_write
from .._parallel import chunk_map
from ..inner_products import (
    ChannelError,
    InnerProduct,
    channel_digest,
    checked_gram,
    get_inner_product,
    known_inner_products,
    rigid_motion_change,
    split_channels,  # the channel vocabulary lives in opnet.inner_products; importable from here as before
)
from ..shape_difference import base_pinvs, fast_path

__all__ = [
    "split_channels",
    "resolve",
    "compute_operators",
    "cache_path",
    "read_cached",
    "write_cached",
    "warn_if_not_rigid",
    "RIGID_TOLERANCE",
]

#: Relative change of ``Φᵀ M Φ`` under a rigid motion of the base above which adding a channel warns.
RIGID_TOLERANCE = 1e-6
# Shapes per task when a channel without project_batch is computed shape by shape in processes.
_CHUNK = 32
# Shapes per chunk of the fast path (one task each on a cluster).
_FAST_CHUNK = 1024


def resolve(channels, held: tuple, digests: dict, instances: dict, *, where: str = "the collection") -> list:
    """``[(name, instance or None)]`` of ``channels`` asked of a collection holding the channels ``held``
    (``digests``: their recorded digests; ``instances``: the inner products it was given this session), in the order
    asked.

    A name it holds needs no instance (``None`` when none is known); an instance must have the digest it recorded.
    A channel it does not hold raises a :class:`~opnet.inner_products.ChannelError` naming ``with_channels``.
    """
    items = split_channels(channels)
    if not items:
        raise ChannelError(f"no channels asked for; name at least one of {where}'s {list(held)}.")
    out = []
    for item in items:
        if isinstance(item, str) and item in held:
            name, ip = item, instances.get(item) or known_inner_products().get(item)
            if ip is not None and digests.get(name) not in (None, channel_digest(ip)):
                ip = None  # the registered one is another implementation: the stored operators still select
        else:
            try:
                ip = get_inner_product(item)
            except ChannelError as exc:
                raise ChannelError(f"{exc} {where.capitalize()} holds {list(held)}.") from None
            name = ip.name
            if name not in held:
                raise ChannelError(
                    f"{where} holds the channels {list(held)}, not {name!r}: add it with "
                    f"collection.with_channels([*collection.channels, {_show(item)}])."
                )
            recorded = digests.get(name)
            if recorded is not None and recorded != channel_digest(ip):
                raise ChannelError(
                    f"{where}'s channel {name!r} was computed by another implementation of it (digest {recorded}; "
                    f"this {type(ip).__name__} has {channel_digest(ip)}): its code or parameters changed since. "
                    "Compute it again with collection.with_channels([...], recompute=True), or give the new class "
                    "another name."
                )
        out.append((name, ip))
    names = [n for n, _ in out]
    if len(set(names)) != len(names):
        raise ChannelError(f"channels names a channel twice: {names}; give each once.")
    return out


def _show(item) -> str:
    if isinstance(item, InnerProduct):
        return f"{type(item).__name__}()"
    return repr(item)


def warn_if_not_rigid(ip: InnerProduct, basis) -> None:
    """Warn when ``ip`` changes under a rigid motion of the base shape: OperatorNet's loss does not see rigid motions,
    so its input should not either.
    """
    mesh = basis.mesh
    change = rigid_motion_change(ip, mesh.vertices, mesh.faces, basis.evecs)
    if change > RIGID_TOLERANCE:
        warn_user(
            f"channel {ip.name!r} is not invariant to rigid motions: Φᵀ M Φ of the base changes by {change:.2g} "
            "(relative) under a rotation and translation. OperatorNet's loss is rigid-invariant, so these operators "
            "carry how each shape is placed, which the network is not asked to recover; check it with "
            "opnet.testing.check_inner_product."
        )


def compute_operators(
    ip: InnerProduct, basis, vertices: np.ndarray, *, n_jobs: int | None = None, progress: bool | None = None
) -> np.ndarray:
    """Shape differences ``(N, k, k)`` float32 of one channel for shapes ``(N, n, 3)`` on the base's faces.

    With a :meth:`~opnet.InnerProduct.project_batch` of its own, in batches (the fast path; a built-in's batches in
    ``n_jobs`` threads); otherwise shape by shape, in ``n_jobs`` processes; ``n_jobs`` as joblib's (default, or
    -1: all cores; 1: in this process). A progress bar over the shapes.

    Under a cluster's joblib backend (``with joblib.parallel_config(backend="dask"):``, see the docs' *Beyond one
    machine*), both run as tasks on its workers (but with ``n_jobs=1``): the fast path one task per chunk of 1024
    shapes (each on its worker machine's cores), the other on all of the cluster's workers.
    """
    vertices = np.asarray(vertices)
    k0_pinvs = base_pinvs(basis, [ip])  # once for all the shapes
    if type(ip).project_batch is not InnerProduct.project_batch:
        threads = None if n_jobs in (None, -1) else n_jobs
        here = n_jobs == 1
        return chunked_operators(basis, vertices, [ip], k0_pinvs, threads=threads, here=here, progress=progress)[:, 0]
    k0_pinv = k0_pinvs[0]
    chunks = [vertices[s : s + _CHUNK] for s in range(0, len(vertices), _CHUNK)]
    bar = tqdm(total=len(vertices), desc=f"channel {ip.name}", unit="shape", disable=_hidden(progress, len(chunks)))
    parts = []
    try:
        if n_jobs == 1 or len(chunks) == 1:
            results = (_project_chunk(ip, k0_pinv, basis.mesh.faces, basis.evecs, c) for c in chunks)
        else:
            from .._extras import require

            joblib = require("joblib", "Collection.with_channels (channels without project_batch, in processes)")
            parallel = joblib.Parallel(n_jobs=-1 if n_jobs is None else n_jobs, return_as="generator")
            task = joblib.delayed(_project_chunk)
            results = parallel(task(ip, k0_pinv, basis.mesh.faces, basis.evecs, c) for c in chunks)
        for part in results:
            parts.append(part)
            bar.update(len(part))
    finally:
        bar.close()
    return np.concatenate(parts) if parts else np.zeros((0, basis.k, basis.k), np.float32)


def chunked_operators(
    basis, vertices, ips, k0_pinvs=None, *, threads=None, here: bool = False, progress=None
) -> np.ndarray:
    """Shape differences ``(N, len(ips), k, k)`` float32 of shapes ``(N, n, 3)`` (checked already) on the base's
    faces, by the fast path in chunks of 1024 shapes (float64 chunks of a float32 collection, ~30 MB each at 1k
    vertices): one after the other here, each in ``threads`` threads, or as tasks on a cluster's workers unless
    ``here`` (:func:`opnet._parallel.chunk_map`). ``k0_pinvs``: the base's :func:`~opnet.shape_difference.base_pinvs` of
    ``ips`` when computed already. A progress bar over the chunks.
    """
    k0_pinvs = base_pinvs(basis, ips) if k0_pinvs is None else k0_pinvs
    starts = range(0, len(vertices), _FAST_CHUNK)
    out = np.empty((len(vertices), len(ips), basis.k, basis.k), np.float32)
    task = partial(_fast_path_chunk, basis, ips, k0_pinvs, threads)
    results = chunk_map(task, [vertices[s : s + _FAST_CHUNK] for s in starts], here=here)
    desc = "shape differences" if len(ips) > 1 else f"channel {ips[0].name}"
    for s, part in zip(
        starts, tqdm(results, total=len(starts), desc=desc, unit="chunk", disable=_hidden(progress, len(starts)))
    ):
        out[s : s + len(part)] = part
    return out


def _fast_path_chunk(basis, ips, k0_pinvs, threads, vertices) -> np.ndarray:
    """:func:`~opnet.shape_difference.fast_path` of one chunk of (checked) shapes, float32."""
    return fast_path(basis, vertices.astype(np.float64), ips, k0_pinv=k0_pinvs, threads=threads).astype(np.float32)


def _hidden(progress, batches: int) -> bool:
    return not (batches > 1 if progress is None else progress)


def _project_chunk(ip, k0_pinv, faces, evecs, vertices) -> np.ndarray:
    return np.stack(
        [k0_pinv @ checked_gram(ip, "project", v.astype(np.float64), faces, evecs) for v in vertices]
    ).astype(np.float32)


def cache_path(stem: Path, name: str, digest: str, data_sha: str) -> Path:
    """Where the operators of channel ``name`` (``digest``) of the collection stored under ``stem`` are cached."""
    safe = re.sub(r"[^A-Za-z0-9_-]+", "_", name).strip("_") or "channel"
    return stem.with_name(f"{stem.name}.channel.{safe}.{digest}.{data_sha[:12]}.npz")


def read_cached(path: Path, name: str, digest: str, shape: tuple) -> np.ndarray | None:
    """The cached operators ``shape`` at ``path`` when they are this channel's (else ``None``: computed again)."""
    if not path.is_file():
        return None
    try:
        with np.load(path) as z:
            identity = json.loads(str(z["identity"]))
            operators = z["operators"]
    except (OSError, ValueError, KeyError, EOFError):
        return None  # damaged: it is computed again and replaced
    if identity.get("name") != name or identity.get("digest") != digest or operators.shape != shape:
        return None
    return operators


def write_cached(path: Path, name: str, digest: str, operators: np.ndarray) -> bool:
    """Cache one channel's operators at ``path`` atomically; a failed write warns (the result is still returned)."""
    identity = json.dumps({"name": name, "digest": digest})
    try:
        atomic_write(path, lambda f: np.savez(f, operators=operators.astype(np.float32), identity=np.array(identity)))
    except OSError as exc:
        warn_user(f"channel {name!r} could not be cached at {path} ({exc}); it will be computed again.")
        return False
    return True
