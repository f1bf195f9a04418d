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
  against (its SfL / FuncChar rows);
- ``init=vertices``: start from a decoded shape, e.g. OperatorNet's output — OperatorNet + refinement.

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
from .mesh import check_shapes, unique_edges
from .shape_difference import KINDS, pinv_psd
from .spectral import Eigenbasis, cotan_edge_weights
from .torch_ops import ShapeDifferences

__all__ = ["reconstruct", "truncate_operators", "operator_mismatch", "OPTIMIZERS"]

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
