"""Shape difference operators ``D^K = K_0⁺ (Cᵀ K_i C)`` (eqs. 2–4 and 7–8 of the paper).

Two ways to evaluate ``Cᵀ K_i C``:

* **explicit** (any functional map): ``K_i = Φ_iᵀ M_i Φ_i`` in the target's own basis,
  carried over by ``C``; this is the paper's formula and needs the target's eigenbasis.
* **fast path** (meshes in 1-1 correspondence with a full target basis, the paper's
  training setting): ``C = Φ_iᵀ A_i Φ_0`` and ``Φ_i Φ_iᵀ A_i = I`` give
  ``Cᵀ K_i C = Φ_0ᵀ M_i Φ_0``, which needs only the base basis. This is what
  :func:`shape_difference` does when ``fmap`` is omitted, and what
  :func:`shape_differences` does for a whole collection at once.
"""

from __future__ import annotations

from contextlib import closing
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from ._backend import left_multiply
from ._checks import check_int, real_array
from ._deprecation import renamed_keyword
from ._parallel import thread_map
from .fmaps import FunctionalMap
from .inner_products import (
    CHANNEL_SETS,
    KINDS,
    batch_grams,
    checked_gram,
    get_inner_product,
    get_inner_products,
    is_built_in,
)
from .mesh import Mesh, check_shapes, check_spans, report_quality
from .spectral import Eigenbasis

__all__ = ["shape_difference", "shape_differences", "distortion_function", "pinv_psd", "KINDS", "CHANNEL_SETS"]


class NotPositiveError(ValueError):
    """A matrix given as positive semi-definite has clearly negative eigenvalues."""


def pinv_psd(K: np.ndarray, rtol: float | None = None) -> np.ndarray:
    """Moore–Penrose pseudo-inverse of a symmetric PSD matrix ``(k, k)``.

    Eigenvalues below ``rtol`` times the largest are treated as zero (e.g. the constant
    function in the kernel of ``Λ`` or of ``Φᵀ E^D Φ``, which is ~1e-16 relative in
    practice). The default ``10 k ε`` keeps the genuine modes of very thin meshes.
    Eigenvalues below ``-1e-6`` times the largest magnitude raise a ``ValueError``: the
    matrix is not PSD, so it is no inner product.
    """
    K = real_array("K", K)
    if K.ndim != 2 or K.shape[0] != K.shape[1] or len(K) == 0:
        raise ValueError(f"K must be a square (k, k) matrix with k >= 1, got shape {K.shape}.")
    K = 0.5 * (K + K.T)
    rtol = 10 * len(K) * np.finfo(float).eps if rtol is None else rtol
    w, U = np.linalg.eigh(K)
    if w.size and w.min() < -1e-6 * np.abs(w).max():
        raise NotPositiveError(
            f"the matrix is not positive semi-definite (eigenvalue {w.min():.3g}, largest "
            f"{w.max():.3g}); an inner product's Φᵀ M Φ must be, so M must be."
        )
    keep = w > rtol * max(w.max(), 0.0)
    return (U[:, keep] / w[keep]) @ U[:, keep].T


def base_pinvs(base_basis: Eigenbasis, channels) -> list[np.ndarray]:
    """``K_0⁺`` ``(k, k)`` of each channel on the base: the left factor of every shape difference ``D = K_0⁺ K``."""
    base = base_basis.mesh
    out = []
    for ip in map(get_inner_product, channels):
        try:
            out.append(pinv_psd(checked_gram(ip, "project", base.vertices, base.faces, base_basis.evecs)))
        except NotPositiveError as exc:
            raise ValueError(f"{type(ip).__name__}.project (inner product {ip.name!r}) on the base: {exc}") from None
    return out


def check_base(base_basis) -> None:
    if not isinstance(base_basis, Eigenbasis):
        raise TypeError(
            f"base_basis must be an opnet.Eigenbasis (opnet.eigenbasis(base_mesh, k)), got {type(base_basis).__name__}."
        )


def shape_difference(base_basis: Eigenbasis, target, kind="area", fmap: FunctionalMap | None = None) -> np.ndarray:
    """The shape difference ``D^K_{0i}`` ``(k_0, k_0)`` of ``target`` seen from the base.

    Parameters
    ----------
    base_basis : Eigenbasis
        Eigenbasis of the base shape ``S_0`` (``k_0`` functions).
    target : Mesh or array (n, 3)
        The shape ``S_i``. An array is read as new coordinates of the base's faces.
    kind : {"area", "conformal", "extrinsic"} or InnerProduct
        ``"area"``: ``Cᵀ C``; ``"conformal"``: ``Λ_0⁺ Cᵀ Λ_i C``; ``"extrinsic"``:
        ``(Φ_0ᵀ E^D_0 Φ_0)⁺ Cᵀ Φ_iᵀ E^D_i Φ_i C``; an InnerProduct: ``K_0⁺ Cᵀ K_i C``.
    fmap : FunctionalMap, optional
        Map from the base to ``target`` (its ``target`` basis is used for ``K_i``). When
        omitted, the meshes must be in 1-1 correspondence and the fast path (identity
        map, full target basis) is used.
    """
    check_base(base_basis)
    ip = get_inner_product(kind)
    base = base_basis.mesh
    if isinstance(target, (str, Path)):
        raise TypeError(
            f"target must be an opnet.Mesh or coordinates ({base.n_vertices}, 3), got the path {target!r}; "
            "read the file with opnet.load_mesh(path)."
        )
    if not isinstance(target, Mesh):
        target = base.with_vertices(target)
    if fmap is None:
        if target.n_vertices != base.n_vertices:
            raise ValueError(
                f"the target has {target.n_vertices} vertices and the base {base.n_vertices}: without a 1-1 "
                "correspondence pass fmap=opnet.fmap_from_p2p(...) or opnet.fmap_from_soft_map(...)."
            )
        Ki = checked_gram(ip, "project", target.vertices, target.faces, base_basis.evecs)
    else:
        if not isinstance(fmap, FunctionalMap):
            raise TypeError(f"fmap must be an opnet.FunctionalMap, got {type(fmap).__name__}.")
        if fmap.source is not base_basis:
            raise ValueError("fmap.source is not base_basis: build the functional map from this base eigenbasis.")
        t = fmap.target.mesh
        if t is not target and not (
            np.array_equal(t.vertices, target.vertices) and np.array_equal(t.faces, target.faces)
        ):
            raise ValueError(
                "fmap.target is the eigenbasis of another mesh than target; pass the mesh the map goes to."
            )
        C = fmap.matrix
        Ki = C.T @ checked_gram(ip, "project", t.vertices, t.faces, fmap.target.evecs) @ C
    return base_pinvs(base_basis, [ip])[0] @ Ki


@renamed_keyword("kinds", "channels")
def shape_differences(
    base_basis: Eigenbasis,
    vertices: np.ndarray,
    channels=KINDS,
    *,
    batch_size: int = 128,
    progress: bool | None = None,
) -> np.ndarray:
    """Shape differences of many shapes in 1-1 correspondence with the base (fast path).

    Parameters
    ----------
    base_basis : Eigenbasis
        Base eigenbasis (``k`` functions, ``n`` vertices).
    vertices : (B, n, 3) array
        Coordinates of ``B`` shapes sharing the base's faces.
    channels : sequence of channels
        Each ``"area"``, ``"conformal"``, ``"extrinsic"`` or an InnerProduct (default the three,
        :data:`~opnet.inner_products.KINDS`).
    batch_size : int
        Shapes evaluated together, one batch per core (memory grows as ``cores · batch_size · (faces + k²)``).
    progress : bool, optional
        Show a progress bar (default: when more than one batch).

    Returns
    -------
    (B, len(channels), k, k) float64
    """
    check_base(base_basis)
    base = base_basis.mesh
    ips = get_inner_products(channels)
    vertices = real_array("vertices", vertices, ("B", base.n_vertices, 3), hint="to share the base's faces")
    check_int("batch_size", batch_size)
    return fast_path(base_basis, vertices, ips, batch_size=batch_size, progress=progress, check="vertices")


def fast_path(
    base_basis: Eigenbasis,
    vertices: np.ndarray,
    ips: list,
    *,
    batch_size: int = 128,
    progress: bool | None = False,
    k0_pinv: list | None = None,
    threads: int | None = None,
    check: str | None = None,
) -> np.ndarray:
    """:func:`shape_differences` of float64 shapes ``(B, n, 3)`` on the base's faces, for inner products ``ips``.
    ``k0_pinv``: the base's :func:`base_pinvs` of ``ips`` when the caller computed them already (a loop over chunks
    of shapes).

    ``check``: the shapes' name, to check them as :func:`opnet.mesh.check_shapes` does (refused with a
    ``ValueError`` naming ``check`` and the first bad shape, or warned about), their face qualities found in the
    operators' own pass over the faces (a separate pass took a quarter of the time); ``None`` for shapes checked
    already.

    Batches of the built-in channels run in ``threads`` threads (default one per usable core) with a single-threaded
    BLAS, also when one thread is enough (numpy's elementwise geometry uses one core: two batches side by side use
    both; and the operators do not depend on the number of threads); any other channel's batches run one after the
    other in this thread, with the BLAS's threads (its ``project_batch`` may not be safe to call from two threads).
    Memory grows as ``threads · batch_size · (faces + k²)``.
    """
    phi, faces = base_basis.evecs, base_basis.mesh.faces
    if check is not None:
        check_spans(check, vertices)
    k0_pinv = base_pinvs(base_basis, ips) if k0_pinv is None else k0_pinv
    out = np.empty((len(vertices), len(ips), base_basis.k, base_basis.k))
    worst = None if check is None else np.empty(len(vertices))  # each shape's worst face quality
    starts = range(0, len(vertices), batch_size)

    def one(s):
        chunk = vertices[s : s + batch_size]
        grams = batch_grams(ips, chunk, faces, phi, None if worst is None else worst[s : s + len(chunk)])
        if grams is None:  # a collapsed face: the whole check names every such shape (and raises)
            quality = check_shapes(check, vertices, faces, batch_size=batch_size)
            worst[s : s + len(chunk)] = quality[s : s + len(chunk)]  # at the limit, where the check's rounding passed
            grams = batch_grams(ips, chunk, faces, phi)
        for c, (kp, gram) in enumerate(zip(k0_pinv, grams)):
            out[s : s + len(chunk), c] = left_multiply(kp, gram)

    show = len(starts) > 1 if progress is None else progress
    built_in = all(map(is_built_in, ips))
    if not built_in:
        threads = 1  # a channel of one's own: in this thread, with the BLAS's threads (they are its own to use)
    with closing(thread_map(one, starts, threads=threads, hold_blas=built_in)) as batches:
        for _ in tqdm(batches, total=len(starts), desc="shape differences", unit="batch", disable=not show):
            pass
    if worst is not None:
        report_quality(check, worst)  # near-degenerate faces: a warning
    return out


def distortion_function(D: np.ndarray, base_basis: Eigenbasis) -> np.ndarray:
    """The eigenfunction of ``D`` with the largest eigenvalue, as a vertex function ``(n,)`` on the base.

    Following Rustamov et al., it highlights where the target is most distorted with
    respect to the inner product of ``D`` (figure "eigenfuncs" of the paper). Its sign is
    chosen so that its largest entry is positive; it is ``A``-normalised on the base.
    """
    check_base(base_basis)
    D = real_array("D", D, (base_basis.k, base_basis.k), hint="to match the base basis")
    w, V = np.linalg.eig(D)
    f = base_basis.evecs @ np.real(V[:, np.argmax(w.real)])
    f /= np.sqrt(np.sum(base_basis.mass * f**2))
    return f if f[np.abs(f).argmax()] > 0 else -f
