"""Evaluation (section 6): methods × metrics × test sets, as in the paper's Table 1.

Methods are :class:`Method` objects: a name and a function from shape indices of a collection to
reconstructed vertices. These are provided:

- :func:`operatornet_method`: a trained :class:`opnet.OperatorNet` decoding the shapes' operators;
- :func:`pointnet_method`: a point-set autoencoder (:class:`opnet.model.PointNetAutoencoder`, the paper's baseline
  of section 7, or one of the other :data:`opnet.model.ARCHITECTURES`) encoding and decoding the shapes'
  coordinates;
- :func:`nearest_neighbour_method`: the training shape whose operators (the same channels, Frobenius
  norm) are nearest (the paper's "NN" row);
- :func:`base_shape_method`: the base shape itself, whatever the input (the "do nothing" floor);
- :func:`geometric_method`: vertices moved from the base until their operators match (no learning);
- :func:`sfl_method`: Shape-from-Laplacian, a shape from its full Laplacian (the paper's "SfL" row);
- :func:`refined_method`: another method's output, moved until its operators match the input's.

Test sets (:data:`TEST_SETS`): ``"eval_subset"`` (the paper's protocol: 5 shapes per held-out
sequence chosen by furthest-point sampling, 50 in all), all of ``"test"`` (10 held-out sequences), and
``"test_subjects"`` (every shape of unseen body types). A collection of several species (the animals,
``meta["species"]``) also has ``"unseen_species"``: the shapes of ``test_subjects`` whose body is one whole species
(no blend), one never seen in training (:data:`SPECIES_SETS`).

Metrics per shape (:func:`shape_errors`): ``d_R`` (eq. 9, length², reported ×10⁻⁴ like the paper),
``d_V`` (relative volume error) and ``d_E`` (mean relative edge-length error); rows hold their means and
medians.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ._checks import check_int, real_array
from ._deprecation import renamed_keyword
from .inner_products import ChannelError, InnerProduct, channel_label, channel_names  # the channel vocabulary
from .mesh import edge_face_counts
from .metrics import d_E, d_R, d_V, rigid_align

__all__ = [
    "TEST_SETS",
    "SPECIES_SETS",
    "test_sets_for",
    "Method",
    "decode",
    "test_set_indices",
    "channel_label",
    "channel_names",
    "SETS",
    "predict",
    "operatornet_method",
    "pointnet_method",
    "sfl_method",
    "nearest_neighbour",
    "OperatorIndex",
    "nearest_neighbour_method",
    "base_shape_method",
    "geometric_method",
    "refined_method",
    "ensemble_method",
    "shape_errors",
    "summarize",
    "vertex_errors",
    "evenly_spaced",
    "evaluate",
]

#: The test sets that :func:`evaluate` reports by default (this module's docstring says what each holds).
TEST_SETS = ("eval_subset", "test", "test_subjects")
#: The test sets of a collection of several species: also the species held out whole (``"unseen_species"``).
SPECIES_SETS = (*TEST_SETS, "unseen_species")
#: Every set :func:`evaluate` can report on: the test sets, and ``"val"`` (where experiments are chosen).
SETS = ("val", *SPECIES_SETS)


def test_sets_for(collection) -> tuple:
    """The test sets to report for ``collection``: :data:`SPECIES_SETS` for one of several species (the animals),
    else :data:`TEST_SETS`.
    """
    return SPECIES_SETS if collection.meta.get("species") else TEST_SETS


def test_set_indices(collection, test_set: str) -> np.ndarray:
    """Shape indices of a set: ``"eval_subset"`` (the 50-shape subset), ``"test"``, ``"test_subjects"``, ``"val"``,
    or, for a collection of several species, ``"unseen_species"``.
    """
    if test_set == "eval_subset":
        return np.asarray(collection.eval_subset)
    if test_set == "unseen_species":
        species = collection.meta.get("species")
        if not species:
            raise ValueError(
                f"test set 'unseen_species' needs a collection of several species (meta['species']: the animals); "
                f"{getattr(collection, 'name', 'this collection')!r} has none: use one of {TEST_SETS}."
            )
        held = collection.indices("test_subjects")
        return held[np.isin(collection.subject[held], list(species))]
    if test_set in ("test", "test_subjects", "val"):
        return collection.indices(test_set)
    raise ValueError(f"unknown test set {test_set!r}; use one of {SETS}.")


@dataclass
class Method:
    """A reconstruction method: ``reconstruct(indices) → (len(indices), n, 3)`` vertices of a collection.

    ``info``: the structured fields its rows carry (its run's, or ``baseline``; given when it is built, never set
    afterwards). ``max_shapes``: evaluate it on at most this many shapes of each test set, evenly spaced (for slow
    methods). ``measures``: ``measures(indices) → dict`` of further fields of a row measured on the same shapes (a
    refined method's ``d_R_before``), not counted in its time.
    """

    name: str
    reconstruct: Callable[[np.ndarray], np.ndarray]
    channels: tuple = ()
    depth: int | None = None
    info: dict = field(default_factory=dict)
    max_shapes: int | None = None
    measures: Callable[[np.ndarray], dict] | None = field(default=None, repr=False)

    def __post_init__(self):
        check_int("max_shapes", self.max_shapes, none_ok=True)


def predict(net, operators, *, batch_size: int = 256) -> np.ndarray:
    """Run a network on its inputs in batches, without gradient → vertices ``(N, n, 3)`` float64.

    ``operators``: ``(N, C, k, k)`` (the network's channels, in its order) for OperatorNet, coordinates
    ``(N, m, 3)`` for the PointNet autoencoder.
    """
    check_int("batch_size", batch_size)
    return _predict(net, real_array("operators", operators, dtype=np.float32), batch_size)


def _predict(net, operators: np.ndarray, batch_size: int = 256) -> np.ndarray:
    """:func:`predict` of inputs already checked (a finite float32 array)."""
    import torch

    device = next(net.parameters()).device
    net.eval()
    out = []
    with torch.no_grad():
        for s in range(0, len(operators), batch_size):
            x = torch.as_tensor(operators[s : s + batch_size], device=device)
            out.append(net(x).double().cpu().numpy())
    return np.concatenate(out) if out else np.zeros((0, net.n_vertices, 3))


@renamed_keyword("kinds", "channels")
def decode(net, operators, channels=None) -> np.ndarray:
    """Shapes from shape differences: vertices ``(n, 3)`` (or ``(B, n, 3)``) on the base's triangulation, float64.

    ``operators`` ``(C, k, k)`` or ``(B, C, k, k)`` (numpy or torch), whose channels are ``channels`` in order;
    default (``None``) the network's own, ``net.channels``, in its order: what :func:`opnet.encode` gives for the
    collection the network was trained on (``opnet.decode(net, opnet.encode(mesh, collection))``). With
    ``channels`` named, the network's are picked from them, so one encoding (e.g. all three, ``opnet.KINDS``)
    serves networks of any channel subset. The output is in the network's frame: shape differences do not see
    rigid motions, so align it (:func:`opnet.rigid_align`) before comparing.
    """
    if not hasattr(net, "channels") or not hasattr(net, "k"):
        raise TypeError(f"net must be an OperatorNet (opnet.train.load_model(run_dir)), got {type(net).__name__}.")
    ops = real_array("operators", operators, dtype=np.float32)
    if isinstance(channels, (str, InnerProduct)):
        raise TypeError(f"channels must be a sequence of channels, e.g. ({channels!r},), not a single one.")
    named = channels is not None
    channels = channel_names(net.channels if channels is None else channels)
    single = ops.ndim == 3
    batch = ops[None] if single else ops
    if batch.ndim != 4 or batch.shape[1:] != (len(channels), net.k, net.k):
        hint = (
            ""
            if named
            else " (the network's channels, the default; for operators of other channels, e.g. encode's three for "
            "a basis, pass channels=opnet.KINDS)"
        )
        raise ValueError(
            f"operators must be (C, k, k) or (B, C, k, k) with C = {len(channels)} channels {channels}{hint} and "
            f"k = {net.k} (the network's), got shape {ops.shape}."
        )
    missing = [c for c in net.channels if c not in channels]
    if missing:
        raise ValueError(
            f"the network reads {missing}, which the operators (channels {channels}) do not hold; "
            "encode them with channels=net.channels."
        )
    out = _predict(net, batch[:, [channels.index(c) for c in net.channels]])  # float32 already: no copy
    return out[0] if single else out


def _network_operators(net, collection) -> np.ndarray:
    """The collection's operators of a network's channels ``(N, C, k, k)``; refused when the network was trained on
    another implementation of one of them (its ``channel_digests``, set by :func:`opnet.train.fit` and
    :func:`opnet.train.load_model`).
    """
    ops = collection.operators_for(net.channels)
    for name, digest in getattr(net, "channel_digests", {}).items():
        here = collection.digests.get(name)
        if None not in (digest, here) and digest != here:
            raise ChannelError(
                f"the network was trained on channel {name!r} computed by another implementation (digest {digest}) "
                f"than this collection's ({here}); compute it with the class the network was trained with, or train "
                "again."
            )
    return ops


def operatornet_method(net, collection, name: str | None = None, *, info: dict | None = None) -> Method:
    """OperatorNet decoding the collection's operators of its own channels (``info``: its rows' fields)."""
    ops = _network_operators(net, collection)
    name = name or f"OperatorNet ({channel_label(net.channels)})"
    return Method(name, lambda idx: predict(net, ops[idx]), tuple(net.channels), net.depth, dict(info or {}))


def pointnet_method(net, collection, name: str = "PointNet AE", *, info: dict | None = None) -> Method:
    """The PointNet autoencoder reconstructing the collection's shapes from their own coordinates (``info``: its
    rows' fields).
    """
    return Method(name, lambda idx: predict(net, collection.vertices[idx]), info=dict(info or {}))


class OperatorIndex:
    """The ``train`` shapes' stacked operators of some channels, for nearest-neighbour queries."""

    def __init__(self, collection, channels):
        self.collection, self.chans = collection, collection.channel_indices(channels)
        self.train = collection.indices("train")
        self.A = collection.operators[self.train][:, self.chans].reshape(len(self.train), -1).astype(np.float64)
        self.a2 = np.einsum("ij,ij->i", self.A, self.A)

    def query(self, indices, chunk: int = 512) -> np.ndarray:
        """Nearest ``train`` shape of each of the collection's shapes ``indices``."""
        out = np.empty(len(indices), dtype=np.int64)
        for s in range(0, len(indices), chunk):
            out[s : s + chunk] = self.nearest(
                self.collection.operators[np.asarray(indices[s : s + chunk])][:, self.chans]
            )
        return out

    def nearest(self, operators) -> np.ndarray:
        """Nearest ``train`` shape (collection index) of each of ``operators`` ``(B, len(channels), k, k)``."""
        B = np.asarray(operators, dtype=np.float64).reshape(len(operators), -1)
        return self.train[np.argmin(self.a2[None, :] - 2 * B @ self.A.T, axis=1)]  # |a - b|² up to |b|²


def nearest_neighbour(collection, indices, channels=None, *, chunk: int = 512) -> np.ndarray:
    """Index (into the collection) of the ``train`` shape whose operators are nearest, for each of ``indices``.

    Distance: Frobenius norm of the difference of the stacked operators of ``channels`` (default all of the
    collection's).
    """
    return OperatorIndex(collection, collection.channels if channels is None else channels).query(indices, chunk)


def nearest_neighbour_method(collection, channels=None, name: str | None = None, *, info: dict | None = None) -> Method:
    """The paper's NN baseline: retrieve the nearest training shape by operator distance (``channels``: default all of
    the collection's; give a network's to compare on the same input). ``info``: its rows' fields (default
    ``baseline`` ``"nearest_neighbour"``).
    """
    channels = collection.channel_names(collection.channels if channels is None else channels)
    name = name or f"Nearest neighbour ({channel_label(channels)})"
    index = OperatorIndex(collection, channels)
    info = dict(baseline="nearest_neighbour") if info is None else dict(info)
    return Method(name, lambda idx: collection.vertices[index.query(idx)].astype(np.float64), channels, info=info)


def base_shape_method(collection, *, info: dict | None = None) -> Method:
    """The base shape for every input: the error of doing nothing (``info``: its rows' fields, default ``baseline``
    ``"base_shape"``).
    """
    base = collection.base_basis.mesh.vertices
    info = dict(baseline="base_shape") if info is None else dict(info)
    return Method("Base shape", lambda idx: np.broadcast_to(base, (len(idx), *base.shape)).copy(), info=info)


def geometric_method(
    collection, channels=None, *, max_shapes: int | None = None, info: dict | None = None, **options
) -> Method:
    """The geometric baseline: :func:`opnet.reconstruct` from the base shape (the paper's FuncChar kind of row),
    i.e. :func:`refined_method` of :func:`base_shape_method` (its rows' ``d_R_before`` is the base shape's error).

    ``options`` go to :func:`opnet.reconstruct` (``steps``, ``smoothness``, ...); ``info``: its rows' fields (default
    ``baseline`` ``"geometric"``).
    """
    return refined_method(
        base_shape_method(collection),
        collection,
        channels,
        max_shapes=max_shapes,
        name=f"Geometric ({channel_label(collection.channels if channels is None else channels)})",
        info=dict(baseline="geometric") if info is None else info,
        **options,
    )


def sfl_method(collection, *, max_shapes: int | None = None, info: dict | None = None, **options) -> Method:
    """Shape-from-Laplacian (the paper's "SfL" row of Table 1): :func:`opnet.geometric.shape_from_laplacian` from the
    base shape, given each test shape's *full* cotan Laplacian on the base's triangulation (computed from its true
    vertices: the paper ran it "with the full basis in both the base shape and the target shape"), not its truncated
    shape differences.

    It needs the shapes on the base's triangulation in known correspondence: a collection on other faces, or whose
    operators come from other meshes through maps (:func:`opnet.data.mapped_collection`), is refused. ``options`` go to
    :func:`~opnet.geometric.shape_from_laplacian` (``metric_steps``, ``embedding_steps``, ``device``); ``info``: its
    rows' fields (default ``baseline`` ``"sfl"``).
    """
    from .geometric import shape_from_laplacian
    from .spectral import areas_and_cotan_weights

    base = collection.base_basis.mesh
    if collection.faces.shape != base.faces.shape or not np.array_equal(collection.faces, base.faces):
        raise ValueError(
            "Shape-from-Laplacian reads each shape's full Laplacian on the base's triangulation; this collection's "
            "shapes are on other faces. Use a collection whose shapes share the base's faces."
        )
    if "maps" in collection.meta:
        raise ValueError(
            f"Shape-from-Laplacian is given each shape's full Laplacian on the base's triangulation, in known "
            f"correspondence (the paper's full basis on both shapes); this collection's operators come from its "
            f"shapes' {collection.meta.get('map_resolution')} meshes through {collection.meta['maps']} maps. Evaluate "
            "it on the collection they were mapped from."
        )

    def run(idx):
        masses, weights = areas_and_cotan_weights(collection.vertices[idx].astype(np.float64), base.faces)
        return shape_from_laplacian(weights, masses, base, progress=False, **options)

    info = dict(baseline="sfl") if info is None else dict(info)
    return Method("SfL (full Laplacian)", run, info=info, max_shapes=max_shapes)


def refined_method(
    method: Method,
    collection,
    channels=None,
    *,
    max_shapes: int | None = None,
    name: str | None = None,
    info: dict | None = None,
    **options,
) -> Method:
    """``method`` followed by :func:`opnet.reconstruct` from its output: its vertices move until their operators
    (``channels``, default all of the collection's; each needs a ``project_torch``) match the input's. ``options`` go
    to :func:`opnet.reconstruct`. Its rows also hold ``d_R_before``, the mean ``d_R`` of ``method`` on the same
    shapes (:attr:`Method.measures`). ``name``: default ``"<method> + refinement"``; ``info``: its rows' fields.
    """
    from .geometric import reconstruct

    ips = collection.inner_products(collection.channels if channels is None else channels)
    channels = tuple(ip.name for ip in ips)
    chans = collection.channel_indices(channels)

    def run(idx):
        return reconstruct(
            collection.operators[idx][:, chans],
            collection.base_basis,
            init=method.reconstruct(idx),
            channels=ips,
            progress=False,
            **options,
        )

    def before(idx):  # the start's error on the same shapes
        return dict(d_R_before=float(np.mean(d_R(collection.vertices[idx], method.reconstruct(idx)))))

    name = name or f"{method.name} + refinement"
    return Method(name, run, channels, method.depth, dict(info or {}), max_shapes, before)


def ensemble_method(methods, name: str | None = None, *, info: dict | None = None) -> Method:
    """The mean of several methods' reconstructions of the same collection (e.g. networks trained with other seeds or
    on other bodies), each first moved rigidly onto the first one's (Kabsch: the loss, eq. 9, leaves each network's
    placement free). Its rows carry the first method's channels and depth; it is evaluated on at most the fewest
    shapes any member allows (``max_shapes``).

    Parameters
    ----------
    methods : sequence of Method
        At least two, reconstructing the same collection's shapes (``(N, n, 3)`` each).
    name : str, optional
        Default ``"Ensemble of <count>"``.
    info : dict, optional
        Its rows' structured fields.
    """
    methods = list(methods)
    if len(methods) < 2 or not all(isinstance(m, Method) for m in methods):
        raise ValueError(f"an ensemble needs two or more Method objects, got {[type(m).__name__ for m in methods]}.")

    def run(idx):
        first = methods[0].reconstruct(idx)
        return np.mean([first, *(rigid_align(m.reconstruct(idx), first) for m in methods[1:])], axis=0)

    first = methods[0]
    limits = [m.max_shapes for m in methods if m.max_shapes is not None]  # as slow as its slowest member
    name = name or f"Ensemble of {len(methods)}"
    return Method(name, run, first.channels, first.depth, dict(info or {}), min(limits, default=None))


def shape_errors(gt, recon, faces, *, batch_size: int = 256) -> dict:
    """Per-shape ``d_R`` (length²), ``d_V`` and ``d_E`` of reconstructions ``(N, n, 3)`` against ``gt``.

    ``d_V`` is NaN for open meshes, whose volume is undefined.
    """
    gt, recon = real_array("gt", gt), real_array("recon", recon)
    closed = bool(np.all(edge_face_counts(np.asarray(faces))[1] == 2))
    out = {"d_R": [], "d_V": [], "d_E": []}
    for s in range(0, len(gt), batch_size):
        g, r = gt[s : s + batch_size], recon[s : s + batch_size]
        out["d_R"].append(d_R(g, r))
        out["d_V"].append(d_V(g, r, faces) if closed else np.full(len(g), np.nan))
        out["d_E"].append(d_E(g, r, faces))
    return {k: np.concatenate(v) if v else np.zeros(0) for k, v in out.items()}


def vertex_errors(gt, recon) -> np.ndarray:
    """Per-vertex distance ``(..., n)`` between ``gt`` and ``recon`` rigidly aligned onto it (length)."""
    return np.linalg.norm(rigid_align(recon, gt) - np.asarray(gt, dtype=np.float64), axis=-1)


def summarize(errors: dict) -> dict:
    """Mean and median of per-shape errors (:func:`shape_errors`): keys ``d_R``, ``d_R_median``, ``d_V``, ..."""
    out = {}
    for key, values in errors.items():
        out[key], out[f"{key}_median"] = float(np.mean(values)), float(np.median(values))
    return out


def evenly_spaced(indices, count: int) -> np.ndarray:
    """At most ``count`` of ``indices``, evenly spaced from the first to the last (all of them when fewer)."""
    indices = np.asarray(indices)
    if len(indices) <= count:
        return indices
    return indices[np.linspace(0, len(indices) - 1, count).round().astype(int)]


def evaluate(
    collection, methods, test_sets=TEST_SETS, *, extra: dict | None = None, per_shape: bool = False
) -> list[dict]:
    """One row per (method, test set): ``method`` (its display name), ``channels`` (a list of channel names; empty
    for a method that reads no operators), ``depth``, ``split``, ``n_shapes``,
    ``seconds_per_shape`` (the method's wall time over the set, per shape) and the mean and median of ``d_R``
    (length²), ``d_V``, ``d_E`` (keys ``d_R``, ``d_R_median``, ...).

    ``methods``: :class:`Method` objects; ``test_sets``: any of :data:`SETS` (``"val"`` to choose between
    experiments); ``extra``: fields added to every row (e.g. the preset); ``per_shape``: rows also hold each shape's
    errors (``d_R_shapes``, ``d_V_shapes``, ``d_E_shapes``: lists in the set's order, and ``shapes``: the indices),
    what a paired comparison needs (:mod:`opnet.experiments.stats`).
    """
    rows = []
    for m in methods:
        for ts in test_sets:
            idx = test_set_indices(collection, ts)
            if len(idx) == 0:
                continue
            if m.max_shapes is not None:
                idx = evenly_spaced(idx, m.max_shapes)
            start = time.perf_counter()
            recon = m.reconstruct(idx)
            seconds = (time.perf_counter() - start) / len(idx)
            err = shape_errors(collection.vertices[idx], recon, collection.faces)
            measured = {} if m.measures is None else m.measures(idx)
            row = dict(
                method=m.name,
                channels=list(m.channels),
                depth=m.depth,
                split=ts,
                n_shapes=int(len(idx)),
                seconds_per_shape=seconds,
            )
            each = {f"{k}_shapes": v.tolist() for k, v in err.items()} | {"shapes": idx.tolist()} if per_shape else {}
            rows.append({**row, **summarize(err), **measured, **each, **m.info, **(extra or {})})
    return rows
