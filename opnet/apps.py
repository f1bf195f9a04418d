"""Applications (section 7, Appendix C): interpolation and analogy as shapes, and their ground-truth benchmarks.

The operator algebra (:func:`opnet.interpolate`, eq. 6, and :func:`opnet.analogy`, ``D_X = D_C D_A⁺ D_B``)
works on shape differences; a :class:`ShapeAlgebra` turns its results into shapes. It is three steps:
``encode`` shapes into a representation, combine representations, ``decode`` the result::

    alg = opnet.apps.operatornet_algebra(net, ds)                 # operators, multiplicative, decoded by OperatorNet
    path = alg.interpolate(i, j, np.linspace(0, 1, 11))             # (11, n, 3): shape i → shape j
    X = alg.analogy(a, b, c)                                        # (n, 3): X is to c what b is to a

The representations, and how they combine:

- :func:`operatornet_algebra`: the shapes' operators (the collection's channels), combined by the operator algebra
  (``scheme="multiplicative"`` as in the paper, or ``"linear"``: ``(1 − t) D_0 + t D_1`` and
  ``D_C + D_B − D_A``), decoded by a trained :class:`opnet.OperatorNet`; ``refine=`` then moves the decoded
  shape until its operators match the synthesised ones (:func:`opnet.reconstruct`).
- :func:`pointnet_algebra`: a PointNet autoencoder's codes, combined linearly (``z_C + z_B − z_A``).
- :func:`nearest_neighbour_algebra`: operators combined as above, then the training shape with the nearest
  operators is retrieved (the paper's NN).

Shapes are given as vertices ``(n, 3)`` / ``(B, n, 3)`` on the collection's mesh, or as indices into it. The
networks decode up to a rigid motion (their loss, eq. 9, does not see one), so every answer is returned rigidly
aligned onto the base shape: upright, in the collection's frame.

Ground truth (:func:`analogy_quadruples`, :func:`interpolation_paths`): the generated collections know the
parameters of every shape, so the benchmark can ask for shapes they do not hold — subject ``b`` in subject
``a``'s pose, a body half-way between two subjects — and score every method against them
(:func:`analogy_benchmark`, :func:`interpolation_benchmark`). Subjects are drawn from ``test_subjects`` and
poses from the ``test`` sequences only.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ._checks import check_int, is_integer, real_array
from .algebra import analogy as operator_analogy
from .algebra import interpolate as operator_interpolate
from .evaluate import OperatorIndex, predict, shape_errors, summarize
from .metrics import d_E, d_R, rigid_align
from .shape_difference import shape_differences

__all__ = [
    "ShapeAlgebra",
    "operatornet_algebra",
    "pointnet_algebra",
    "nearest_neighbour_algebra",
    "SCHEMES",
    "Quadruples",
    "analogy_quadruples",
    "analogy_benchmark",
    "Paths",
    "interpolation_paths",
    "interpolation_benchmark",
    "path_metrics",
    "nan_stat",
    "ANALOGY_KINDS",
    "PATH_KINDS",
]

#: How operators are combined: the paper's multiplicative algebra (eq. 6, ``D_C D_A⁺ D_B``) or linear.
SCHEMES = ("multiplicative", "linear")
#: Analogy benchmark kinds: "pose" (a, p) : (a, q) :: (b, p) : (b, q); "body" (a, p) : (b, p) :: (a, q) : (b, q);
#: "gender" (a♂, p) : (a♀, p) :: (b♂, q) : (b♀, q) (subjects with a gender phenotype: the humans, heads and hands).
ANALOGY_KINDS = ("pose", "body", "gender")
#: Interpolation path kinds: "pose" (one subject between two poses of a test sequence), "body" (one pose between
#: two unseen subjects).
PATH_KINDS = ("pose", "body")


@dataclass(eq=False)
class ShapeAlgebra:
    """Interpolation and analogy of shapes through a representation: ``decode(combine(encode(shapes)))``.

    ``encode``: vertices ``(B, n, 3)`` float64 → representations ``(B, ...)``; ``decode``: the inverse way.
    ``space``: ``"operators"`` (``(B, C, k, k)``, all of the collection's channels, combined by ``scheme``) or
    ``"latent"`` (codes ``(B, L)``, combined linearly). ``max_shapes``: the benchmarks evaluate a slow method
    on at most this many shapes; ``unrefined``: the method a refined one starts from (its rows then also hold
    ``d_R_before``); ``fields``: the structured fields the benchmarks' rows of this method carry (its run's, or
    ``baseline``), given when it is built. Build one with :func:`operatornet_algebra`, :func:`pointnet_algebra` or
    :func:`nearest_neighbour_algebra`.
    """

    name: str
    collection: object
    encode: Callable[[np.ndarray], np.ndarray]
    decode: Callable[[np.ndarray], np.ndarray]
    space: str = "operators"
    scheme: str = "multiplicative"
    max_shapes: int | None = None
    unrefined: "ShapeAlgebra | None" = field(default=None, repr=False)
    fields: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        if self.space not in ("operators", "latent"):
            raise ValueError(f"space must be 'operators' or 'latent', got {self.space!r}.")
        if self.scheme not in SCHEMES:
            raise ValueError(f"scheme must be one of {SCHEMES}, got {self.scheme!r}.")
        check_int("max_shapes", self.max_shapes, none_ok=True)

    def shapes(self, shapes) -> np.ndarray:
        """Vertices ``(B, n, 3)`` float64 of indices into the collection or of vertices ``(n, 3)``/``(B, n, 3)``."""
        return _as_shapes(self.collection, shapes)

    def reconstruct(self, shapes) -> np.ndarray:
        """``decode(encode(shapes))``: each shape through the representation and back ``(B, n, 3)``."""
        return self._decode(self.encode(self.shapes(shapes)))

    def _decode(self, R) -> np.ndarray:
        """``decode``, rigidly aligned onto the base shape (see the module docstring)."""
        X = np.asarray(self.decode(R), dtype=np.float64)
        base = self.collection.base_basis.mesh.vertices
        return rigid_align(X, np.broadcast_to(base, X.shape))

    def interpolate(self, start, end, t=np.linspace(0, 1, 11)) -> np.ndarray:
        """Shapes ``(len(t), n, 3)`` from ``start`` (``t = 0``) to ``end`` (``t = 1``), each an index or ``(n, 3)``."""
        t = np.atleast_1d(real_array("t", t))
        if t.ndim != 1 or len(t) == 0:
            raise ValueError(f"t must be a number or a non-empty 1-d array, got shape {np.shape(t)}.")
        S = np.concatenate([self.shapes(start), self.shapes(end)])
        if len(S) != 2:
            raise ValueError(f"interpolate takes one start shape and one end shape, got {len(S)} shapes.")
        R0, R1 = self.encode(S)
        if self.space == "latent":
            return self._decode((1 - t)[:, None] * R0 + t[:, None] * R1)
        mixed = np.stack([operator_interpolate(R0[c], R1[c], t, self.scheme) for c in range(len(R0))], axis=1)
        return self._decode(mixed)

    def analogy(self, A, B, C) -> np.ndarray:
        """``X`` is to ``C`` what ``B`` is to ``A``: one shape ``(n, 3)``, or ``(Q, n, 3)`` for ``Q`` triples."""
        single = all(_is_single(x) for x in (A, B, C))
        SA, SB, SC = (self.shapes(x) for x in (A, B, C))
        if not len(SA) == len(SB) == len(SC):
            raise ValueError(f"A, B and C must hold as many shapes each, got {len(SA)}, {len(SB)} and {len(SC)}.")
        RA, RB, RC = (self.encode(x) for x in (SA, SB, SC))
        if self.space == "latent" or self.scheme == "linear":
            RX = RC + RB - RA
        else:
            RX = np.array(
                [[operator_analogy(a, b, c) for a, b, c in zip(qa, qb, qc)] for qa, qb, qc in zip(RA, RB, RC)]
            )
        X = self._decode(RX)
        return X[0] if single else X


def _is_single(x) -> bool:
    return is_integer(x) or np.ndim(x) == 2


def _as_shapes(collection, shapes) -> np.ndarray:
    n = collection.vertices.shape[1]
    if (
        is_integer(shapes)
        or (isinstance(shapes, (list, tuple)) and shapes and all(map(is_integer, shapes)))
        or (isinstance(shapes, np.ndarray) and shapes.ndim == 1 and shapes.dtype.kind in "iu")
    ):
        idx = np.atleast_1d(np.asarray(shapes, dtype=np.int64))
        if idx.min() < -len(collection) or idx.max() >= len(collection):
            raise IndexError(
                f"shape index out of range: the collection has {len(collection)} shapes, got {idx.tolist()}."
            )
        return collection.vertices[idx].astype(np.float64)
    V = real_array("shapes", shapes, hint=f"(indices into the collection, or vertices (n, 3) / (B, n, 3), n = {n})")
    V = V[None] if V.ndim == 2 else V
    if V.ndim != 3 or V.shape[1:] != (n, 3) or len(V) == 0:
        raise ValueError(
            f"shapes must be vertices (n, 3) or (B, n, 3) on the collection's mesh (n = {n}), or indices "
            f"into the collection; got an array of shape {np.shape(shapes)}."
        )
    return V


def _operators(collection):
    basis = collection.base_basis
    ips = collection.inner_products()  # the channels of a shape's representation: all of the collection's
    return lambda V: shape_differences(basis, V, ips, progress=False)


def operatornet_algebra(
    net,
    collection,
    *,
    scheme: str = "multiplicative",
    refine: dict | None = None,
    max_shapes: int | None = None,
    name: str | None = None,
    fields: dict | None = None,
) -> ShapeAlgebra:
    """Shapes → their operators → the operator algebra (``scheme``) → a trained OperatorNet → shapes.

    ``refine``: options of :func:`opnet.reconstruct` (e.g. ``dict(channels=("area", "extrinsic"), steps=300)``):
    the decoded shapes then move until their operators match the synthesised ones (seconds per shape; set
    ``max_shapes`` to bound the benchmarks). ``name`` defaults to ``"OperatorNet (mult.)"`` / ``"(linear)"``,
    with ``" + refinement"``. ``fields``: its rows' structured fields (:attr:`ShapeAlgebra.fields`).
    """
    if not hasattr(net, "channels"):
        raise TypeError(
            f"operatornet_algebra needs a trained OperatorNet, got a {type(net).__name__} (for the PointNet "
            "autoencoder use pointnet_algebra)."
        )
    chans = collection.channel_indices(net.channels)
    base_name = name or f"OperatorNet ({'mult.' if scheme == 'multiplicative' else 'linear'})"
    plain = ShapeAlgebra(
        base_name,
        collection,
        _operators(collection),
        lambda R: predict(net, R[:, chans]),
        "operators",
        scheme,
        max_shapes if refine is None else None,
        fields=dict(fields or {}),
    )
    if refine is None:
        return plain
    from .geometric import reconstruct

    options = dict(refine)
    if {"init", "progress"} & set(options):
        raise ValueError(
            f"refine= sets options of opnet.reconstruct other than init and progress (the decoded "
            f"shape is the start; no bar per call), got {sorted({'init', 'progress'} & set(options))}."
        )
    options["channels"] = collection.inner_products(options.get("channels", collection.channels))
    ref_chans = collection.channel_indices(options["channels"])

    def decode(R):
        return reconstruct(R[:, ref_chans], collection.base_basis, init=plain.decode(R), progress=False, **options)

    return ShapeAlgebra(
        f"{base_name} + refinement" if name is None else name,
        collection,
        plain.encode,
        decode,
        "operators",
        scheme,
        max_shapes,
        plain,
        dict(fields or {}),
    )


def pointnet_algebra(net, collection, *, name: str = "PointNet AE", fields: dict | None = None) -> ShapeAlgebra:
    """Shapes → a PointNet autoencoder's codes → linear algebra in the code → its decoder → shapes (``fields``: its
    rows' structured fields).
    """
    import torch

    if not (hasattr(net, "encode") and hasattr(net, "decode")):
        raise TypeError(
            f"pointnet_algebra needs a trained PointNetAutoencoder (encode and decode), got a "
            f"{type(net).__name__} (for OperatorNet use operatornet_algebra)."
        )
    device = next(net.parameters()).device

    def run(f, x):
        net.eval()
        with torch.no_grad():
            return f(torch.as_tensor(np.asarray(x, dtype=np.float32), device=device)).double().cpu().numpy()

    encode, decode = lambda V: run(net.encode, V), lambda Z: run(net.decode, Z)
    return ShapeAlgebra(name, collection, encode, decode, "latent", fields=dict(fields or {}))


def nearest_neighbour_algebra(
    collection,
    channels=None,
    *,
    scheme: str = "multiplicative",
    name: str | None = None,
    fields: dict | None = None,
) -> ShapeAlgebra:
    """Operators combined by the algebra (``scheme``), then the ``train`` shape with the nearest operators of
    ``channels`` (Frobenius; default all of the collection's) is returned: the paper's NN, which can only answer
    with shapes it has seen. ``fields``: its rows' structured fields (default ``baseline`` ``"nearest_neighbour"``).
    """
    channels = collection.channels if channels is None else channels
    index = OperatorIndex(collection, channels)
    chans = collection.channel_indices(channels)
    return ShapeAlgebra(
        name or "Nearest neighbour",
        collection,
        _operators(collection),
        lambda R: collection.vertices[index.nearest(R[:, chans])].astype(np.float64),
        "operators",
        scheme,
        fields=dict(baseline="nearest_neighbour") if fields is None else dict(fields),
    )


# ---------------------------------------------------------------------------------------------------------
# ground truth from the generator


def ground_truth_pool(collection):
    """Unseen subjects' phenotypes ``(S, 6)`` and the ``test`` sequences' shapes (indices) and their sequence names."""
    from .data.generators import generated_name

    generated_name(collection)
    subj_idx = collection.indices("test_subjects")
    pose_idx = collection.indices("test")
    if len(subj_idx) == 0 or len(pose_idx) == 0:
        raise ValueError(
            "the ground-truth benchmarks draw subjects from 'test_subjects' and poses from 'test'; this "
            "collection has none of one of them."
        )
    subjects = np.unique(collection.params["phenotypes"][subj_idx].astype(np.float64), axis=0)
    return subjects, pose_idx, collection.subcollection[pose_idx]


@dataclass
class Quadruples:
    """Analogy questions with their answers: ``A : B :: C : X``, vertices ``(Q, n, 3)`` each, and their ``kind``.

    ``phenotypes`` ``(Q, 2, 6)``: the subjects ``a``, ``b`` of each question (a gender transfer: as in ``A`` and
    ``C``, male); ``poses`` ``(Q, 2)``: the collection
    indices of the ``test`` shapes whose poses are ``p``, ``q`` (see :func:`analogy_quadruples` for the roles).
    """

    kind: str
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    X: np.ndarray
    labels: list = field(default_factory=list)
    phenotypes: np.ndarray | None = None
    poses: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.X)


def analogy_quadruples(collection, kind: str = "pose", n: int = 100, *, seed: int = 0) -> Quadruples:
    """``n`` analogy questions with ground truth, from the generator's parameters (humans, heads or hands).

    Two unseen subjects ``a ≠ b`` (``test_subjects``) and two poses ``p``, ``q`` of different ``test`` sequences:

    - ``kind="pose"`` (pose transfer): ``(a, p) : (a, q) :: (b, p) : X = (b, q)``;
    - ``kind="body"`` (body-type transfer): ``(a, p) : (b, p) :: (a, q) : X = (b, q)``;
    - ``kind="gender"`` (gender transfer, the paper's Figs. 10 and 13): ``(a♂, p) : (a♀, p) :: (b♂, q) : X = (b♀, q)``,
      where ``a♂`` is subject ``a`` with the gender phenotype set to male (0) and ``a♀`` to female (1), the rest of
      the subject unchanged: ``A`` and ``B`` differ by gender alone, ``C`` varies (another subject, another pose).
      The paper keeps one fixed ``A``/``B`` pair for all its questions; here each question draws its own, so that
      the rows average over pairs as well.

    The four shapes are generated anew (:func:`opnet.data.generators.generate_shapes`); ``seed`` draws them (each
    kind its own draws, so that the kinds are independent samples: the linear algebra, ``C + B − A``, would
    give both kinds the same answer).
    """
    from .data.generators import generate_shapes, generated_name
    from .data.profiles import profile_of
    from .data.subjects import PHENOTYPES

    if kind not in ANALOGY_KINDS:
        raise ValueError(f"kind must be one of {ANALOGY_KINDS}, got {kind!r}.")
    check_int("n", n)
    subjects, pose_idx, sequences = ground_truth_pool(collection)
    if kind == "gender" and "gender" not in profile_of(generated_name(collection)).analogy_kinds:
        raise ValueError(
            f"gender analogies set the subjects' gender phenotype (column {PHENOTYPES.index('gender')} of "
            f"{PHENOTYPES}); this collection's profile names no gender transfer ({generated_name(collection)!r}'s "
            "subjects have no gender): use the humans, heads or hands."
        )
    if len(subjects) < 2 or len(set(sequences)) < 2:
        raise ValueError(
            f"analogies need two unseen subjects and two test sequences; this collection has "
            f"{len(subjects)} and {len(set(sequences))}: use a larger preset."
        )
    rng = np.random.default_rng([seed, ANALOGY_KINDS.index(kind)])  # each kind its own draws
    a, b, p, q = [], [], [], []
    while len(a) < n:
        i, j = rng.choice(len(subjects), 2, replace=False)
        u, v = rng.choice(len(pose_idx), 2, replace=False)
        if sequences[u] != sequences[v]:
            a.append(i), b.append(j), p.append(pose_idx[u]), q.append(pose_idx[v])
    controls = collection.params["controls"]
    labels = [
        f"subjects {i}/{j}, poses {collection.subcollection[u]}#{u}/{collection.subcollection[v]}#{v}"
        for i, j, u, v in zip(a, b, p, q)
    ]
    who = dict(labels=labels, phenotypes=np.stack([subjects[a], subjects[b]], axis=1), poses=np.stack([p, q], axis=1))
    if kind == "gender":
        g = PHENOTYPES.index("gender")
        male_a, female_a, male_b, female_b = (subjects[s].copy() for s in (a, a, b, b))
        male_a[:, g], female_a[:, g], male_b[:, g], female_b[:, g] = 0.0, 1.0, 0.0, 1.0
        phen = np.concatenate([male_a, female_a, male_b, female_b])
        ctrl = np.concatenate([controls[p], controls[p], controls[q], controls[q]])
        who["phenotypes"] = np.stack([male_a, male_b], axis=1)  # A's and C's subjects (B and X: female)
        return Quadruples(kind, *np.split(generate_shapes(collection, phen, ctrl), 4), **who)
    phen = np.concatenate([subjects[a], subjects[a], subjects[b], subjects[b]])
    ctrl = np.concatenate([controls[p], controls[q], controls[p], controls[q]])
    ap, aq, bp, bq = np.split(generate_shapes(collection, phen, ctrl), 4)
    if kind == "pose":
        return Quadruples(kind, ap, aq, bp, bq, **who)
    return Quadruples(kind, ap, bp, aq, bq, **who)


@dataclass
class Paths:
    """Interpolation paths with their ground truth: ``truth`` ``(P, T, n, 3)`` at parameters ``t`` ``(T,)``;
    ``truth[:, 0]`` and ``truth[:, -1]`` are the endpoints.
    """

    kind: str
    t: np.ndarray
    truth: np.ndarray
    labels: list = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.truth)


def interpolation_paths(collection, kind: str = "pose", n_paths: int = 10, steps: int = 11, *, seed: int = 0) -> Paths:
    """``n_paths`` paths of ``steps`` shapes with the generator's true in-between shapes.

    - ``kind="pose"``: an unseen subject (``test_subjects``, drawn by ``seed``) moving from the first pose of a
      ``test`` sequence to the pose of that sequence that differs most from it (the sequences in turn); the true
      in-between has every joint turned part of the way (:func:`opnet.data.generators.interpolate_controls`).
    - ``kind="body"``: one ``test`` pose (drawn), from an unseen subject ``a`` to another ``b``; the true in-between
      has the phenotype ``(1 − t) a + t b``.

    All shapes, the ends included, are generated anew, as for :func:`analogy_quadruples`.
    """
    from .data.generators import generate_shapes, interpolate_controls

    if kind not in PATH_KINDS:
        raise ValueError(f"kind must be one of {PATH_KINDS}, got {kind!r}.")
    check_int("n_paths", n_paths)
    check_int("steps", steps, minimum=2)
    subjects, pose_idx, sequences = ground_truth_pool(collection)
    controls = collection.params["controls"]
    t = np.linspace(0, 1, steps)
    rng = np.random.default_rng([seed, PATH_KINDS.index(kind)])
    phen, ctrl, labels = [], [], []
    if kind == "pose":
        names = sorted(set(sequences))
        for k in range(n_paths):
            members = pose_idx[sequences == names[k % len(names)]]
            start = members[0]
            end = members[np.argmax([np.linalg.norm(controls[m] - controls[start]) for m in members])]
            i = rng.integers(len(subjects))
            phen.append(np.repeat(subjects[i][None], steps, 0))
            ctrl.append(interpolate_controls(collection, controls[start], controls[end], t))
            labels.append(f"subject {i}, poses {collection.subcollection[start]} #{start} → #{end}")
    else:
        if len(subjects) < 2:
            raise ValueError("body paths need two unseen subjects (test_subjects); use a larger preset.")
        for k in range(n_paths):
            i, j = rng.choice(len(subjects), 2, replace=False)
            p = pose_idx[rng.integers(len(pose_idx))]
            phen.append((1 - t)[:, None] * subjects[i] + t[:, None] * subjects[j])
            ctrl.append(np.repeat(controls[p][None].astype(np.float64), steps, 0))
            labels.append(f"subject {i} → {j}, pose {collection.subcollection[p]}#{p}")
    V = generate_shapes(collection, np.concatenate(phen), np.concatenate(ctrl))
    return Paths(kind, t, V.reshape(n_paths, steps, *V.shape[1:]), labels)


# ---------------------------------------------------------------------------------------------------------
# benchmarks


def _subset(method: ShapeAlgebra, n: int) -> int:
    return n if method.max_shapes is None else min(n, method.max_shapes)


def analogy_benchmark(
    collection, methods, quadruples, *, progress: bool | None = None, per_shape: bool = False
) -> list[dict]:
    """One row per (method, quadruple kind): ``method``, ``kind``, ``n``, the mean and median ``d_R`` (length²),
    ``d_V``, ``d_E`` of the synthesised ``X`` against the true one, and ``d_R_direct``: the same method's error on
    ``X`` given ``X`` itself (its reconstruction floor: what is left is the algebra's error). Refined methods add
    ``d_R_before`` (their unrefined method on the same quadruples); each row also holds its method's
    :attr:`~ShapeAlgebra.fields`.

    ``methods``: :class:`ShapeAlgebra` objects; ``quadruples``: a :class:`Quadruples` or a list of them.
    ``per_shape``: each row also holds ``shapes`` (the questions' indices) and the per-question ``d_R_shapes``,
    ``d_V_shapes``, ``d_E_shapes``, for paired comparisons (:func:`opnet.experiments.compare`).
    """
    from tqdm.auto import tqdm

    quadruples = [quadruples] if isinstance(quadruples, Quadruples) else list(quadruples)
    rows = []
    bar = tqdm(total=len(methods) * len(quadruples), desc="analogies", unit="method", disable=progress is False)
    for m in methods:
        for Q in quadruples:
            q = _subset(m, len(Q))
            X = m.analogy(Q.A[:q], Q.B[:q], Q.C[:q])
            err = shape_errors(Q.X[:q], X, collection.faces)
            row = dict(method=m.name, kind=Q.kind, n=int(q), scheme=m.scheme if m.space == "operators" else "latent")
            row.update(summarize(err))
            if per_shape:
                row["shapes"] = list(range(q))
                row |= {f"{key}_shapes": np.asarray(err[key], np.float64).tolist() for key in ("d_R", "d_V", "d_E")}
            row["d_R_direct"] = float(np.mean(d_R(Q.X[:q], m.reconstruct(Q.X[:q]))))
            if m.unrefined is not None:
                row["d_R_before"] = float(np.mean(d_R(Q.X[:q], m.unrefined.analogy(Q.A[:q], Q.B[:q], Q.C[:q]))))
            rows.append({**row, **m.fields})
            bar.update(1)
    bar.close()
    return rows


def path_metrics(path, truth, faces) -> dict:
    """Quality of one interpolation path ``(T, n, 3)`` against its ground truth ``(T, n, 3)`` (same ``t``).

    - ``endpoint_d_R``: mean ``d_R`` of the path's two ends against the true ends (length²);
    - ``distortion``: the largest, over the steps, mean relative edge-length error (``d_E``) against the nearer
      true endpoint (0 for a path that bends without stretching);
    - ``smoothness``: the largest jump between consecutive steps (RMS vertex distance after rigid alignment)
      divided by the path's length (the sum of the jumps); ``1 / (T − 1)`` for evenly spaced steps, up to 1 for a
      path that jumps at once; NaN for a path that does not move (length under 10⁻⁹ of the shape's size);
    - ``d_R_truth``: mean ``d_R`` of the inner steps (both ends when ``T = 2``) against the true in-between shapes
      (length²).

    ``distortion`` and ``d_R_truth`` are measured against the truth, so they include the method's own
    reconstruction error (``endpoint_d_R`` shows its size at the ends).
    """
    path, truth = np.asarray(path, np.float64), np.asarray(truth, np.float64)
    T = len(path)
    size = float(np.linalg.norm(truth[0].max(0) - truth[0].min(0)))  # the bounding box's diagonal
    nearer = np.where(np.arange(T) <= (T - 1) / 2, 0, T - 1)
    jumps = np.sqrt(d_R(path[:-1], path[1:]))
    inner = slice(1, T - 1) if T > 2 else slice(0, T)
    return dict(
        endpoint_d_R=float(np.mean(d_R(truth[[0, -1]], path[[0, -1]]))),
        distortion=float(np.max(d_E(truth[nearer], path, faces))),
        smoothness=float(jumps.max() / jumps.sum()) if jumps.sum() > 1e-9 * size else float("nan"),
        d_R_truth=float(np.mean(d_R(truth[inner], path[inner]))),
    )


def nan_stat(stat, values) -> float:
    """``stat`` (``np.nanmean``, ``np.nanmax``) of ``values`` without their NaNs (a stuck path's smoothness); NaN,
    without numpy's warning, when every value is NaN (every path stuck: the row's ``stuck_paths`` says so).
    """
    values = np.asarray(values, dtype=float)
    return float("nan") if np.isnan(values).all() else float(stat(values))


def interpolation_benchmark(
    collection, methods, paths, *, progress: bool | None = None, per_shape: bool = False
) -> list[dict]:
    """One row per (method, path kind): ``method``, ``kind``, ``scheme``, ``n_paths``, ``steps`` and the means over
    the paths of :func:`path_metrics` (plus the worst ``smoothness``, ``smoothness_max``). A first row per kind,
    ``"Ground truth"``, scores the true paths themselves (their own distortion: what bending costs in edge lengths).
    A method's rows also hold its :attr:`~ShapeAlgebra.fields`.

    ``paths``: a :class:`Paths` or a list of them; ``methods``: :class:`ShapeAlgebra` objects. ``per_shape``: each
    row also holds ``shapes`` (the paths' indices) and each metric per path (``smoothness_shapes``...), for paired
    comparisons (:func:`opnet.experiments.compare`).
    """
    from tqdm.auto import tqdm

    paths = [paths] if isinstance(paths, Paths) else list(paths)
    rows = []
    bar = tqdm(total=(len(methods) + 1) * len(paths), desc="interpolation", unit="method", disable=progress is False)
    for P in paths:
        for m in [None, *methods]:
            n = len(P) if m is None else min(len(P), -(-_subset(m, len(P) * len(P.t)) // len(P.t)))
            made = [P.truth[i] if m is None else m.interpolate(P.truth[i, 0], P.truth[i, -1], P.t) for i in range(n)]
            metrics = [path_metrics(x, P.truth[i], collection.faces) for i, x in enumerate(made)]
            if m is None:  # the truth against itself: exactly 0 (not rounding noise)
                metrics = [dict(r, endpoint_d_R=0.0, d_R_truth=0.0) for r in metrics]
            row = dict(method="Ground truth" if m is None else m.name, kind=P.kind, n_paths=n, steps=len(P.t))
            if m is not None:  # as the analogy's rows: what tells the two algebras of one network apart
                row["scheme"] = m.scheme if m.space == "operators" else "latent"
            for key in metrics[0]:
                row[key] = nan_stat(np.nanmean, [r[key] for r in metrics])
            if per_shape:
                row["shapes"] = list(range(n))
                row |= {f"{key}_shapes": [float(r[key]) for r in metrics] for key in metrics[0]}
            row["smoothness_max"] = nan_stat(np.nanmax, [r["smoothness"] for r in metrics])
            row["stuck_paths"] = int(np.sum([np.isnan(r["smoothness"]) for r in metrics]))
            rows.append(row if m is None else {**row, **m.fields})
            bar.update(1)
    bar.close()
    return rows
