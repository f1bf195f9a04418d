"""Shapes from operators by optimisation: the geometric baseline and the refinement of a decoded shape.

:func:`reconstruct` moves the vertices ``X`` ``(B, n, 3)`` of shapes on the base's triangulation until their
differentiable shape differences (:class:`opnet.torch_ops.ShapeDifferences`) match the given operators. It
minimises, per shape,

``Σ_c ‖D_c(X) − D*_c‖²_F / ‖D*_c − D_c(X_0)‖²_F  +  smoothness · E(X − X_init) / area_0``

over the channels ``c``: the first term is the **relative operator mismatch** (1 at the base shape
``X_0``, 0 when the operators match); the second is the Dirichlet energy of the displacement from the
starting shape, ``E(d) = Σ_edges w_ij ‖d_i − d_j‖²`` with the base's cotan weights, divided by the base's
area so that it has no unit. It keeps the displacement smooth where the truncated operators cannot see it.

- ``init="base"``: start from the base shape — the purely geometric reconstruction the paper compares
  against (its FuncChar rows);
- ``init=vertices``: start from a decoded shape, e.g. OperatorNet's output — OperatorNet + refinement.

:func:`shape_from_laplacian` is the paper's other geometric baseline, Shape-from-Laplacian (Boscaini et al.
2015), which reads a shape's *full* cotan Laplacian (its edge weights and vertex masses) instead of truncated
shape differences.

Shapes are optimised independently (in batches); each keeps the iterate with its lowest objective, so a
step that diverges (a triangle collapsing, NaN) never reaches the result.
"""

from __future__ import annotations

import numbers
import warnings

import numpy as np
import torch
from tqdm.auto import tqdm

from ._checks import is_integer, real_array
from .devices import resolve_device
from .inner_products import checked_gram, get_inner_products, split_channels
from .mesh import Mesh, check_shapes, corner_edges, unique_edges
from .shape_difference import KINDS, pinv_psd
from .spectral import Eigenbasis, cotan_edge_weights
from .torch_ops import ShapeDifferences

__all__ = [
    "reconstruct",
    "truncate_operators",
    "operator_mismatch",
    "OPTIMIZERS",
    "shape_from_laplacian",
    "lengths_laplacian",
    "lengths_laplacian_jacobian",
]

#: The optimisers of :func:`reconstruct`: per-shape batched L-BFGS (the default) or Adam.
OPTIMIZERS = ("lbfgs", "adam")


def _as_operators(operators, channels, k) -> torch.Tensor:
    arr = real_array("operators", operators)
    if arr.ndim == 3:
        arr = arr[None]
    if arr.ndim != 4 or arr.shape[1:] != (len(channels), k, k):
        raise ValueError(
            f"operators must have shape (B, {len(channels)}, {k}, {k}) — one {k} × {k} matrix per channel "
            f"{channels} of a {k}-function base basis — got {arr.shape}. Pass channels= to match the "
            "operators, and the base basis they were computed with."
        )
    if len(arr) == 0:
        raise ValueError("operators is an empty batch (B = 0); pass at least one shape.")
    return torch.tensor(arr, dtype=torch.float64)


def _as_init(init, base_basis: Eigenbasis, batch: int) -> torch.Tensor:
    base = base_basis.mesh.vertices
    if isinstance(init, str):
        if init != "base":
            raise ValueError(f"init must be 'base' or vertices (B, {len(base)}, 3), got {init!r}.")
        return torch.as_tensor(np.broadcast_to(base, (batch, *base.shape)).copy())
    arr = real_array("init", init)
    if arr.ndim == 2:
        arr = np.broadcast_to(arr, (batch, *arr.shape))
    if arr.shape != (batch, *base.shape):
        raise ValueError(
            f"init must have shape ({batch}, {len(base)}, 3) — one shape per operator set, on the base's "
            f"{len(base)} vertices — got {arr.shape}."
        )
    check_shapes("init", arr, base_basis.mesh.faces)
    return torch.tensor(arr, dtype=torch.float64)


def truncate_operators(operators, base_basis: Eigenbasis, channels, m: int) -> np.ndarray:
    """Shape differences ``(B, C, m, m)`` against ``base_basis.truncate(m)``, from ``operators`` ``(B, C, k, k)``
    against ``base_basis``.

    ``D = K₀⁺ K`` with ``K`` in the range of ``K₀``, so ``K = K₀ D`` and the truncated operator is
    ``(K₀)ₘ⁺ (K₀ D)ₘ`` on the leading ``m × m`` blocks: exact, for every kind (tested against the operators
    computed with the truncated basis).
    """
    ips, k = get_inner_products(channels), base_basis.k
    operators = real_array("operators", operators, ("B", len(ips), k, k), hint=f"(channels {tuple(channels)})")
    if not is_integer(m) or not 1 <= m <= k:
        raise ValueError(f"m must be an integer in [1, k={k}] (the base basis has {k} functions), got {m!r}.")
    out = np.empty((len(operators), len(ips), m, m))
    mesh = base_basis.mesh
    for c, ip in enumerate(ips):
        K0 = checked_gram(ip, "project", mesh.vertices, mesh.faces, base_basis.evecs)
        out[:, c] = pinv_psd(K0[:m, :m]) @ (K0 @ operators[:, c])[:, :m, :m]
    return out


def _is_real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def operator_mismatch(
    module: ShapeDifferences, X: torch.Tensor, target: torch.Tensor, scale: torch.Tensor
) -> torch.Tensor:
    """Relative operator mismatch ``(B,)``: ``Σ_c ‖D_c(X) − D*_c‖²_F / scale_c`` for ``target`` ``(B, C, k, k)``."""
    return (((module(X) - target) ** 2).sum((-1, -2)) / scale).sum(-1)


def reconstruct(
    operators,
    base_basis: Eigenbasis,
    *,
    init="base",
    channels=KINDS,
    steps: int = 100,
    optimizer: str = "lbfgs",
    lr: float | None = None,
    smoothness: float = 1.0,
    batch_size: int = 64,
    coarse_to_fine=(),
    device="cpu",
    callback=None,
    progress: bool | None = None,
) -> np.ndarray:
    """Vertices ``(B, n, 3)`` float64 whose shape differences match ``operators``, on the base's triangulation.

    Parameters
    ----------
    operators : array ``(B, C, k, k)`` (or ``(C, k, k)``)
        Shape differences of the channels ``channels`` against ``base_basis`` (e.g. ``collection.operators``).
    base_basis : opnet.Eigenbasis
        The base eigenbasis the operators were computed with (``k`` functions); its faces are the result's.
    init : ``"base"`` or vertices ``(B, n, 3)`` / ``(n, 3)``
        The starting shape (see the module docstring): the base (geometric baseline) or a decoded shape.
    channels : the operators' channels, in their order: names (built-in or registered), inner products, or
        ``"area,extrinsic"``. Each needs :meth:`~opnet.InnerProduct.project_torch` (the built-ins have one).
    steps : optimiser iterations (L-BFGS iterations, each with its line search; or Adam steps).
    optimizer : ``"lbfgs"`` (default: per-shape L-BFGS with Armijo backtracking) or ``"adam"``.
    lr : L-BFGS: the first step moves the vertex with the largest gradient by ``lr`` % of the shape's
        bounding-box diagonal (default 1; later steps are scaled by the curvature pairs). Adam: its step size in
        length units (default 1e-3).
    smoothness : weight of the displacement's Dirichlet energy (0 disables it; default 1).
    batch_size : shapes optimised together (each has its own objective; the batch shares the iterations).
    device : where to compute: ``"cpu"`` (default), ``"cuda"``, or ``"auto"`` (CUDA when available); float64.
    callback : called as ``callback(step, X, mismatch)`` after every step, with ``step`` from 0 (the start),
        ``X`` ``(b, n, 3)`` the current vertices of the batch and ``mismatch`` ``(b,)`` their relative operator
        mismatch (tensors, detached); e.g. to record curves. Batches come one after the other.
    coarse_to_fine : increasing sizes ``m < k``, e.g. ``(20, 40)``: first match the leading ``m × m`` operators
        (:func:`truncate_operators`, on ``base_basis.truncate(m)``) for ``steps`` steps at each size in turn, then
        the full ones for ``steps`` more. ``callback`` then sees the steps of all stages, numbered on.
    progress : show a progress bar over the steps of all batches (default: on).

    Returns
    -------
    (B, n, 3) float64 array: per shape, the iterate with the lowest objective (never NaN).

    Warns
    -----
    RuntimeWarning : (Adam) a step made the objective NaN or infinite (for example a triangle collapsed); those
        shapes go back to their best iterate. L-BFGS accepts only finite steps that decrease the objective.
    """
    if not isinstance(base_basis, Eigenbasis):
        raise TypeError(f"base_basis must be an opnet.Eigenbasis, got {type(base_basis).__name__}.")
    channels = get_inner_products(split_channels(channels))  # instances: each channel's project_torch is used
    target = _as_operators(operators, tuple(ip.name for ip in channels), base_basis.k)
    X_init = _as_init(init, base_basis, len(target))
    if optimizer not in OPTIMIZERS:
        raise ValueError(f"optimizer must be one of {OPTIMIZERS}, got {optimizer!r}.")
    for name, value, positive in (("steps", steps, False), ("batch_size", batch_size, True)):
        if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < int(positive):
            raise ValueError(f"{name} must be a {'positive' if positive else 'non-negative'} integer, got {value!r}.")
    if not (_is_real(smoothness) and np.isfinite(smoothness) and smoothness >= 0):
        raise ValueError(f"smoothness must be a finite number >= 0, got {smoothness!r}.")
    lr = (1.0 if optimizer == "lbfgs" else 1e-3) if lr is None else lr
    if not (_is_real(lr) and np.isfinite(lr) and lr > 0):
        raise ValueError(f"lr must be a positive number, got {lr!r}.")
    smoothness, lr = float(smoothness), float(lr)
    sizes = list(coarse_to_fine)
    if sizes:
        if (
            any(not isinstance(m, (int, np.integer)) or isinstance(m, bool) for m in sizes)
            or sizes != sorted(set(sizes))
            or not 1 <= sizes[0]
            or sizes[-1] >= base_basis.k
        ):
            raise ValueError(
                f"coarse_to_fine must be increasing integer sizes in [1, {base_basis.k - 1}], got {coarse_to_fine!r}."
            )
        X = X_init.numpy()
        options = dict(
            channels=channels,
            steps=steps,
            optimizer=optimizer,
            lr=lr,
            smoothness=smoothness,
            batch_size=batch_size,
            device=device,
            progress=progress,
        )
        for stage, m in enumerate([*sizes, base_basis.k]):

            def staged(step, *args, offset=stage * steps, first=stage == 0):  # a later stage's step 0 repeats
                if first or step > 0:  # the last step of the one before
                    callback(step + offset, *args)

            ops = target.numpy() if m == base_basis.k else truncate_operators(target.numpy(), base_basis, channels, m)
            X = reconstruct(
                ops, base_basis.truncate(m), init=X, callback=None if callback is None else staged, **options
            )
        return X

    device = resolve_device(device)
    module = ShapeDifferences(base_basis, channels, device=device)
    base = torch.tensor(base_basis.mesh.vertices, device=device)[None]
    faces = base_basis.mesh.faces
    edges = torch.as_tensor(unique_edges(faces), device=device)
    w = torch.as_tensor(cotan_edge_weights(base_basis.mesh.vertices, faces) / base_basis.mesh.area, device=device)
    with torch.no_grad():
        at_base = module(base)
    out = np.empty(tuple(X_init.shape))
    bar = tqdm(
        total=steps * -(-len(target) // batch_size),
        desc=f"reconstruct ({optimizer})",
        unit="step",
        disable=progress is False,
    )
    for s in range(0, len(target), batch_size):
        D = target[s : s + batch_size].to(device)
        scale = ((D - at_base) ** 2).sum((-1, -2)).clamp_min(1e-12 * base_basis.k)
        start = X_init[s : s + batch_size].to(device)

        def objective(X, rows=slice(None)):  # X: the shapes `rows` of this batch
            d = X - start[rows]
            smooth = (w * ((d[:, edges[:, 0]] - d[:, edges[:, 1]]) ** 2).sum(-1)).sum(-1)
            mismatch = operator_mismatch(module, X, D[rows], scale[rows])
            return mismatch + smoothness * smooth, mismatch

        minimise = _lbfgs if optimizer == "lbfgs" else _adam
        out[s : s + batch_size] = minimise(objective, start, steps, lr, callback, bar).cpu().numpy()
    bar.close()
    return out


def lengths_laplacian(squared_lengths: torch.Tensor, faces: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
    """The cotan Laplacian of an intrinsic metric: barycentric lumped masses ``(..., n)`` and cotan weights
    ``(..., e)`` (:func:`opnet.spectral.vertex_areas` and :func:`~opnet.spectral.cotan_edge_weights`) from the
    squared edge lengths ``(..., e)`` of ``unique_edges(faces)``, differentiable in them (torch, any float dtype).

    A face with squared lengths ``s₀, s₁, s₂`` (the edge opposite each corner) has ``16 A² = 2(s₀s₁ + s₁s₂ + s₂s₀) −
    (s₀² + s₁² + s₂²)`` (Heron) and ``cot`` of corner ``c`` ``(s_{c+1} + s_{c+2} − s_c) / 4A``. Lengths that break a
    triangle inequality give NaN (no such triangle).
    """
    faces = np.ascontiguousarray(faces)
    opposite = torch.as_tensor(corner_edges(faces, unique_edges(faces)).reshape(-1, 3), device=squared_lengths.device)
    s = squared_lengths[..., opposite]  # (..., m, 3)
    s0, s1, s2 = s.unbind(-1)
    area = torch.sqrt(2 * (s0 * s1 + s1 * s2 + s2 * s0) - (s0**2 + s1**2 + s2**2)) / 4  # (..., m)
    cot = (s.roll(-1, -1) + s.roll(-2, -1) - s) / (4 * area[..., None])  # corner c: s_{c+1} + s_{c+2} - s_c
    weights = torch.zeros_like(squared_lengths).index_add_(-1, opposite.reshape(-1), 0.5 * cot.flatten(-2))
    n = int(faces.max()) + 1
    corners = torch.as_tensor(faces.reshape(-1).copy(), device=squared_lengths.device)
    masses = squared_lengths.new_zeros((*squared_lengths.shape[:-1], n)).index_add_(
        -1, corners, (area[..., None] / 3).expand(*area.shape, 3).flatten(-2)
    )
    return masses, weights


def shape_from_laplacian(
    weights,
    masses,
    base,
    *,
    metric_steps: int = 100,
    embedding_steps: int = 1000,
    batch_size: int = 64,
    device="cpu",
    progress: bool | None = None,
) -> np.ndarray:
    """Shape-from-Laplacian (Boscaini et al. 2015, "Shape-from-operator"): vertices ``(B, n, 3)`` float64 on the
    base's triangulation whose cotan Laplacian is the given one, found from the base shape in two steps.

    1. **Metric from the operator**: the squared edge lengths ``s`` ``(e,)`` whose Laplacian
       (:func:`lengths_laplacian`) matches the target's, the least-squares fit of the residuals
       ``(w(s) − w*) / ‖w*‖`` and ``(a(s) − a*) / ‖a*‖`` over ``log s`` from the base's lengths, shape by shape, by
       Levenberg–Marquardt with the exact sparse Jacobian (:func:`lengths_laplacian_jacobian`:
       each weight and mass reads the edges of the faces around it). The full Laplacian (stiffness and masses)
       fixes the discrete metric: with it, this step finds the target's edge lengths to about 1e-12.
    2. **Embedding from the metric**: the vertices whose edges have those lengths, minimising the least-squares
       stress ``Σ_e (‖x_i − x_j‖ − √s_e)² / Σ_e s_e`` from the base's vertices by :func:`reconstruct`'s batched
       L-BFGS.

    What is the same as Boscaini et al.'s *Shape-from-Laplacian*: its input (the target's full Laplacian on the base's
    triangulation, in known correspondence: the paper's "full basis on both the base and the target shape") and its
    two steps, a metric from the operator, then an embedding of that metric by stress minimisation. What differs:
    the solvers (Levenberg–Marquardt and L-BFGS here), one pass of the two steps (metric, then embedding; no outer
    iterations between them), the stress taken over the edges alone, and no other regularisation. An intrinsic
    metric leaves the embedding free up to isometry: where the target bends the base nearly isometrically (a pose),
    the embedding may keep the base's bend, so edge lengths come back far better than
    positions (the paper's d_E of 0.012 beside a d_R of 48.8 ×10⁻⁴).

    Parameters
    ----------
    weights : array ``(B, e)`` (or ``(e,)``)
        The targets' cotan edge weights on ``unique_edges(base.faces)`` (:func:`opnet.spectral.cotan_edge_weights`).
    masses : array ``(B, n)`` (or ``(n,)``)
        The targets' lumped vertex masses, length² (:func:`opnet.spectral.vertex_areas`).
    base : opnet.Mesh or opnet.Eigenbasis
        The base shape: the start of both steps, and the triangulation of the targets.
    metric_steps : evaluations of the residuals the metric step may spend per shape (its Jacobians aside; the first
        is at the start, so 1 leaves the base's lengths).
    embedding_steps : L-BFGS iterations of the embedding.
    batch_size : shapes embedded together.
    device : where the embedding runs: ``"cpu"`` (default), ``"cuda"`` or ``"auto"``; float64.
    progress : a progress bar over the shapes (default: on).

    Returns
    -------
    (B, n, 3) float64 array.
    """
    import scipy.sparse as sp

    mesh = base.mesh if isinstance(base, Eigenbasis) else base
    if not isinstance(mesh, Mesh):
        raise TypeError(f"base must be an opnet.Mesh or opnet.Eigenbasis, got {type(base).__name__}.")
    faces, X0 = mesh.faces, mesh.vertices
    edges = unique_edges(faces)
    w_target = real_array("weights", weights)
    a_target = real_array("masses", masses)
    w_target = w_target[None] if w_target.ndim == 1 else w_target
    a_target = a_target[None] if a_target.ndim == 1 else a_target
    if w_target.ndim != 2 or w_target.shape[1] != len(edges):
        raise ValueError(
            f"weights must be (B, {len(edges)}): one cotan weight per edge of the base's triangulation "
            f"(unique_edges(base.faces)), got {np.shape(weights)}; a shape on another triangulation needs a map "
            "onto the base first."
        )
    if a_target.shape != (len(w_target), len(X0)):
        raise ValueError(
            f"masses must be ({len(w_target)}, {len(X0)}): one lumped mass per base vertex for each shape, got "
            f"{np.shape(masses)}."
        )
    if not (np.all(np.isfinite(w_target)) and np.all(np.isfinite(a_target)) and np.all(a_target > 0)):
        raise ValueError("weights must be finite and masses finite and positive (a mesh's cotan Laplacian).")
    for name, value in (("metric_steps", metric_steps), ("embedding_steps", embedding_steps)):
        if not is_integer(value) or value < 0:
            raise ValueError(f"{name} must be a non-negative integer, got {value!r}.")
    if not is_integer(batch_size) or batch_size < 1:
        raise ValueError(f"batch_size must be a positive integer, got {batch_size!r}.")
    device = resolve_device(device)
    base_s = ((X0[edges[:, 0]] - X0[edges[:, 1]]) ** 2).sum(-1)
    s = np.empty_like(w_target)
    bar = tqdm(total=2 * len(w_target), desc="shape from Laplacian", unit="step", disable=progress is False)
    for i, (w_star, a_star) in enumerate(zip(w_target, a_target)):  # 1. the metric, shape by shape
        w_norm, a_norm = np.linalg.norm(w_star), np.linalg.norm(a_star)

        def residuals(u, w_star=w_star, a_star=a_star, w_norm=w_norm, a_norm=a_norm):
            a, w = (t.numpy() for t in lengths_laplacian(torch.from_numpy(np.exp(u)), faces))
            r = np.concatenate([(w - w_star) / w_norm, (a - a_star) / a_norm])
            return np.nan_to_num(r, nan=1e3)  # no such triangle: far off, so the trust region shrinks

        def jacobian(u, w_norm=w_norm, a_norm=a_norm):
            J = lengths_laplacian_jacobian(np.exp(u), faces, edges, len(X0))  # in s; in u = log s: times s
            scale = np.concatenate([np.full(len(edges), 1 / w_norm), np.full(len(X0), 1 / a_norm)])
            return (sp.diags(scale) @ J @ sp.diags(np.exp(u))).tocsr()

        if metric_steps:
            s[i] = np.exp(_levenberg_marquardt(residuals, jacobian, np.log(base_s), metric_steps))
        else:
            s[i] = base_s
        bar.update(1)
    e = torch.as_tensor(edges, device=device)
    out = np.empty((len(w_target), *X0.shape))
    for b in range(0, len(w_target), batch_size):  # 2. the embedding, in batches
        lengths = torch.as_tensor(np.sqrt(s[b : b + batch_size]), device=device)
        total = (lengths**2).sum(-1)

        def stress(X, rows=slice(None), lengths=lengths, total=total):
            d = (X[:, e[:, 0]] - X[:, e[:, 1]]).norm(dim=-1)
            f = ((d - lengths[rows]) ** 2).sum(-1) / total[rows]
            return f, f

        start = torch.tensor(X0, device=device).expand(len(lengths), -1, -1).clone()
        quiet = tqdm(disable=True)
        out[b : b + batch_size] = _lbfgs(stress, start, embedding_steps, 1.0, None, quiet).cpu().numpy()
        bar.update(len(lengths))
    bar.close()
    return out


def lengths_laplacian_jacobian(squared_lengths: np.ndarray, faces: np.ndarray, edges: np.ndarray, n: int):
    """The Jacobian ``(e + n, e)`` (scipy sparse) of :func:`lengths_laplacian`'s cotan weights (rows ``0 … e−1``, in
    ``edges`` order) and lumped masses (rows ``e …``) in the squared edge lengths ``(e,)`` of ``edges``
    (``unique_edges(faces)``).

    Per face, with ``A`` its area and ``cot_c`` its corners' cots: ``∂A/∂s_j = cot_j / 4`` and ``∂cot_c/∂s_j = (±1 −
    cot_c cot_j) / 4A`` (``−1`` for the edge opposite ``c``, ``+1`` for the other two); each edge's weight takes half
    the cots opposite it, each corner's vertex a third of the area.
    """
    import scipy.sparse as sp

    opposite = corner_edges(faces, edges).reshape(-1, 3)  # (m, 3): the edge opposite each corner
    s = squared_lengths[opposite]  # (m, 3)
    area = np.sqrt(2 * (s[:, 0] * s[:, 1] + s[:, 1] * s[:, 2] + s[:, 2] * s[:, 0]) - (s**2).sum(1)) / 4
    cot = (np.roll(s, -1, 1) + np.roll(s, -2, 1) - s) / (4 * area[:, None])
    sign = np.where(np.eye(3, dtype=bool), -1.0, 1.0)
    d_cot = (sign - cot[:, :, None] * cot[:, None, :]) / (4 * area[:, None, None])  # (m, c, j)
    d_area = cot / 4  # (m, j)
    rows = np.concatenate([np.repeat(opposite, 3, 1).ravel(), len(edges) + np.repeat(faces, 3, 1).ravel()])
    cols = np.concatenate([np.tile(opposite, (1, 3)).ravel(), np.tile(opposite, (1, 3)).ravel()])
    values = np.concatenate([0.5 * d_cot.ravel(), np.repeat(d_area[:, None, :] / 3, 3, 1).ravel()])
    return sp.csr_matrix((values, (rows, cols)), shape=(len(edges) + n, len(edges)))  # duplicates are summed


def _levenberg_marquardt(residuals, jacobian, x: np.ndarray, steps: int, tol: float = 1e-15) -> np.ndarray:
    """``x`` minimising ``‖residuals(x)‖²``, by Levenberg–Marquardt from ``x``.

    Marquardt's scaling; each step is a sparse direct solve of ``(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr`` (``jacobian(x)``:
    scipy sparse). ``steps`` bounds the evaluations of the residuals; it stops when no step lowers the sum of squares,
    or the sum is below ``tol``. scipy's sparse ``least_squares`` solves these systems iteratively, by LSMR, with
    thousands of iterations each for the ill-conditioned cotan weights: 15 s a shape against about 1 here.
    """
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve

    r = residuals(x)
    f, lam, evaluations = float(r @ r), 1e-3, 1
    while evaluations < steps and f > tol:
        J = jacobian(x)
        JtJ, g = (J.T @ J).tocsc(), J.T @ r
        damping = sp.diags(JtJ.diagonal() + 1e-300)
        while evaluations < steps:
            step = spsolve((JtJ + lam * damping).tocsc(), -g, permc_spec="MMD_ATA")
            r_new = residuals(x + step)
            evaluations += 1
            f_new = float(r_new @ r_new)
            if np.isfinite(f_new) and f_new < f:
                x, r, f, lam = x + step, r_new, f_new, max(lam / 10, 1e-12)
                break
            lam *= 4
            if lam > 1e16:
                return x
        else:
            break
        if np.abs(step).max() < 1e-14:
            break
    return x


def _value_and_grad(objective, X: torch.Tensor, rows=slice(None)):
    """Per-shape objective ``(b,)``, mismatch ``(b,)`` and gradient ``(b, n, 3)`` of the shapes ``rows`` of the
    batch, at ``X`` (their coordinates; shapes are independent). Non-finite objectives come back as ``inf``.
    """
    X = X.detach().requires_grad_(True)
    with torch.enable_grad():
        f, mismatch = objective(X, rows)
        finite = torch.isfinite(f)
        (grad,) = torch.autograd.grad(torch.where(finite, f, torch.zeros_like(f)).sum(), X)
    f = torch.where(finite, f, torch.full_like(f, float("inf")))
    return f.detach(), mismatch.detach(), torch.where(finite[:, None, None], grad, torch.zeros_like(grad))


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum((-1, -2))


def _lbfgs(objective, start: torch.Tensor, steps: int, lr: float, callback, bar, memory: int = 10) -> torch.Tensor:
    """Batched L-BFGS: one independent two-loop recursion and Armijo backtracking per shape.

    ``torch.optim.LBFGS`` treats a batch as one problem (one line search, curvature pairs mixing shapes),
    which stalls the shapes that converge slower; here each shape has its own history and step length.
    The first step moves the vertex with the largest gradient by ``lr`` % of the start's bounding-box
    diagonal; later steps are scaled by the shape's latest valid curvature pair. A trial step is accepted only
    where the objective is finite and decreases enough, so the iterates never diverge. A shape whose line
    search fails forgets its history and retries along the steepest descent; if that fails too (at a minimum,
    or at the objective's rounding noise) it is frozen and costs nothing more.
    """
    X = start.clone()
    f, mismatch, g = _value_and_grad(objective, X)
    diag = (start.amax(1) - start.amin(1)).norm(dim=-1)  # (b,)
    diag = torch.where(diag > 0, diag, torch.ones_like(diag))
    active = torch.isfinite(f) & (g.abs().amax((-1, -2)) > 0)
    steepest = torch.zeros_like(active)  # shapes whose last line search failed: retry along -g, history cleared
    pairs: list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]] = []
    if callback is not None:
        callback(0, X.clone(), mismatch)
    for step in range(1, steps + 1):
        if active.any():
            q, alphas = g.clone(), []
            for s, y, rho in reversed(pairs):
                a = rho * _dot(s, q)
                q -= a[:, None, None] * y
                alphas.append(a)
            first = 0.01 * lr * diag / g.abs().amax((-1, -2)).clamp_min(1e-300)
            gamma = first
            for s, y, rho in pairs:  # the latest pair with positive curvature scales the step
                gamma = torch.where(rho > 0, _dot(s, y) / _dot(y, y).clamp_min(1e-300), gamma)
            r = gamma[:, None, None] * q
            for (s, y, rho), a in zip(pairs, reversed(alphas)):
                r += s * (a - rho * _dot(y, r))[:, None, None]
            d = torch.nan_to_num(-r)
            slope = _dot(g, d)
            reset = active & (steepest | ~(slope < 0))  # not a descent direction: fall back to steepest descent
            d[reset] = -(first[reset, None, None] * g[reset])
            slope = _dot(g, d)
            t = torch.ones_like(f)
            pending = active & (slope < 0)
            X_new, f_new, m_new, g_new = X.clone(), f.clone(), mismatch.clone(), g.clone()
            for _ in range(30):  # backtracking, per shape, on the shapes still searching
                rows = torch.nonzero(pending).squeeze(1)
                trial = X[rows] + t[rows, None, None] * d[rows]
                ft, mt, gt = _value_and_grad(objective, trial, rows)
                ok = ft <= f[rows] + 1e-4 * t[rows] * slope[rows]
                done = rows[ok]
                X_new[done], f_new[done], m_new[done], g_new[done] = trial[ok], ft[ok], mt[ok], gt[ok]
                pending[done] = False
                if not pending.any():
                    break
                t = torch.where(pending, 0.5 * t, t)
            active &= ~(pending & reset)  # no acceptable step even along -g: converged (rounding noise) or stuck
            steepest = pending & ~reset
            pairs = [(s, y, torch.where(steepest, torch.zeros_like(rho), rho)) for s, y, rho in pairs]
            s_k, y_k = X_new - X, g_new - g
            sy = _dot(s_k, y_k)
            curved = sy > 1e-12 * _dot(s_k, s_k).sqrt() * _dot(y_k, y_k).sqrt()
            rho = torch.where(curved & ~reset, 1.0 / sy.clamp_min(1e-300), torch.zeros_like(sy))
            pairs = (pairs + [(s_k, y_k, rho)])[-memory:]
            X, f, mismatch, g = X_new, f_new, m_new, g_new
        if callback is not None:
            callback(step, X.clone(), mismatch)
        bar.update(1)
    return X


def _adam(objective, start: torch.Tensor, steps: int, lr: float, callback, bar) -> torch.Tensor:
    """Adam on the vertices (``lr`` in length units per step); keeps each shape's best finite iterate."""
    X = torch.nn.Parameter(start.clone())
    opt = torch.optim.Adam([X], lr=lr)
    best_X, best_f = start.clone(), None
    for step in range(steps + 1):
        f, mismatch, g = _value_and_grad(objective, X)
        ok = torch.isfinite(f)
        better = ok & (f < best_f) if best_f is not None else ok
        best_f = f if best_f is None else torch.where(better, f, best_f)
        best_X[better] = X.detach()[better]
        if callback is not None:
            callback(step, X.detach().clone(), mismatch)
        if step == steps:
            break
        if not ok.all():
            warnings.warn(
                f"step {step}: the objective of {int((~ok).sum())} shapes became NaN or infinite (a triangle "
                "collapsed?); they restart from their best iterate. Lower lr.",
                RuntimeWarning,
                stacklevel=3,
            )
            with torch.no_grad():
                X.copy_(torch.where(ok[:, None, None], X, best_X))
        X.grad = g
        opt.step()
        bar.update(1)
    return best_X
