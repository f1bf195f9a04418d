"""Figures: meshes with scalar fields (pyvista, static images) and operators as heat maps (matplotlib)."""

from __future__ import annotations

import os

import numpy as np

from ._extras import require
from .mesh import Mesh

__all__ = [
    "headless",
    "use_static_backend",
    "to_pyvista",
    "plot_meshes",
    "plot_operators",
    "plot_reconstructions",
    "plot_mapped_reconstructions",
    "plot_history",
    "plot_refinement_curves",
    "plot_ablation",
    "plot_interpolations",
    "plot_analogies",
]


def headless() -> None:
    """Render pyvista off screen (through EGL when there is no display), e.g. to save screenshots from a script."""
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    pv = require("pyvista", "opnet.plotting")

    pv.OFF_SCREEN = True


def use_static_backend(window_size=(900, 300)) -> None:
    """Render pyvista figures as static PNG images (headless through EGL when there is no display).

    Call it at the top of a notebook so that readers and the test-suite see the same images.
    """
    headless()
    pv = require("pyvista", "opnet.plotting")

    pv.set_jupyter_backend("static")
    _store_renders_as_jpeg()
    pv.global_theme.window_size = list(window_size)
    pv.global_theme.background = "white"
    pv.global_theme.font.color = "black"


def _store_renders_as_jpeg() -> None:
    """Keep only the JPEG form of pyvista's static images in notebooks (the PNG form is ~6× larger)."""
    try:
        import PIL.Image
        from IPython import get_ipython
    except ImportError:
        return
    shell = get_ipython()
    if shell is not None:
        shell.display_formatter.formatters["image/png"].for_type(PIL.Image.Image, lambda _: None)


def to_pyvista(mesh):
    """A :class:`pyvista.PolyData` of a :class:`Mesh` or of a ``(vertices, faces)`` pair."""
    pv = require("pyvista", "opnet.plotting")

    v, f = (mesh.vertices, mesh.faces) if isinstance(mesh, Mesh) else mesh
    f = np.asarray(f)
    return pv.PolyData(np.asarray(v), np.hstack([np.full((len(f), 1), 3), f]).ravel())


def plot_meshes(
    meshes,
    scalars=None,
    titles=None,
    *,
    cmap="coolwarm",
    clim=None,
    cmaps=None,
    clims=None,
    ncols=None,
    camera="yz",
    zoom=1.0,
    window_size=None,
):
    """A pyvista plotter with one mesh per subplot (call ``.show()`` on it, or ``.screenshot(path)``).

    Parameters
    ----------
    meshes : list of Mesh or (vertices, faces)
    scalars : list of (n,) arrays or None, optional
        A vertex function painted on each mesh (``None`` for a plain surface).
    titles : list of str, optional
    cmap, clim : colormap name and (min, max); ``clim`` defaults to each field's own range.
    cmaps, clims : lists, one colormap and one (min, max) or None per mesh, instead of ``cmap`` and ``clim``.
    ncols : subplots per row (default: all in one row).
    camera : str, a pyvista camera position such as ``"yz"`` or ``"xy"``.
    """
    pv = require("pyvista", "opnet.plotting")

    meshes = list(meshes)
    scalars = [None] * len(meshes) if scalars is None else list(scalars)
    titles = [None] * len(meshes) if titles is None else list(titles)
    cmaps = [cmap] * len(meshes) if cmaps is None else list(cmaps)
    clims = [clim] * len(meshes) if clims is None else list(clims)
    if not len(meshes) == len(scalars) == len(titles) == len(cmaps) == len(clims):
        raise ValueError("meshes, scalars, titles, cmaps and clims must have the same length.")
    ncols = ncols or len(meshes)
    nrows = -(-len(meshes) // ncols)
    size = window_size or (300 * ncols, 380 * nrows)
    plotter = pv.Plotter(shape=(nrows, ncols), window_size=list(size), border=False, off_screen=True)
    for i, (m, s, t, cmap, clim) in enumerate(zip(meshes, scalars, titles, cmaps, clims)):
        plotter.subplot(i // ncols, i % ncols)
        kw = dict(smooth_shading=True, show_scalar_bar=False)
        if s is None:
            plotter.add_mesh(to_pyvista(m), color="lightsteelblue", **kw)
        else:
            plotter.add_mesh(to_pyvista(m), scalars=np.asarray(s), cmap=cmap, clim=clim, **kw)
        if t:
            plotter.add_text(t, font_size=10, color="black")
        plotter.camera_position = camera
        plotter.camera.zoom(zoom)
    return plotter


def plot_operators(operators, titles=None, *, vmax=None, cmap="RdBu_r", skip_constant: bool = True):
    """Heat maps of ``k × k`` operators side by side; returns the matplotlib figure.

    The colour range is symmetric about 0, so positive and negative entries read alike. ``vmax`` defaults to
    each operator's largest absolute entry off its first row and column (``skip_constant``): those belong to
    the constant function, on which a conformal or extrinsic ``D − I`` is ``−1`` and would otherwise swamp
    the rest of the map. When that clips entries, they saturate and the figure says so beneath the maps.
    """
    plt = require("matplotlib.pyplot", "opnet.plotting")

    operators = [np.asarray(D) for D in operators]
    titles = titles or [None] * len(operators)
    fig, axes = plt.subplots(1, len(operators), figsize=(3.3 * len(operators), 3.2), squeeze=False)
    clipped = False
    for ax, D, t in zip(axes[0], operators, titles):
        block = D[1:, 1:] if skip_constant and min(D.shape) > 1 else D
        m = vmax or float(np.abs(block).max()) or 1.0
        clipped |= bool(np.abs(D).max() > m)
        im = ax.imshow(D, cmap=cmap, vmin=-m, vmax=m)
        ax.set_title(t)
        ax.set_xticks([])
        ax.set_yticks([])
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    fig.tight_layout()
    if clipped:
        fig.text(
            0.5,
            0.0,
            "colour range set by the entries off the first row and column (the constant function); "
            "those beyond it saturate",
            ha="center",
            va="top",
            fontsize=8,
        )
    return fig


def plot_reconstructions(gt, reconstructions: dict, faces, *, titles=None, clim=None, camera="xz", zoom=1.2):
    """Ground truth beside reconstructions, one shape per row, each reconstruction coloured by its error.

    Parameters
    ----------
    gt : (N, n, 3) ground-truth vertices.
    reconstructions : dict name → (N, n, 3), e.g. ``{"OperatorNet": ..., "NN": ...}``; each is rigidly
        aligned onto the ground truth and painted with its per-vertex distance to it (length unit of the
        input; shared colour range ``clim``, default 0 to the largest error shown).
    faces : (m, 3) shared triangles.
    titles : list of N str, optional, a caption per row (e.g. the shape's sequence).
    """
    gt = np.asarray(gt, dtype=np.float64)
    aligned, errors = {}, {}
    for name, r in reconstructions.items():
        aligned[name], errors[name] = _aligned_errors(r, gt)
    vmax = max(float(e.max()) for e in errors.values()) if clim is None else None
    clim = clim or (0.0, vmax)
    meshes, scalars, labels = [], [], []
    for i in range(len(gt)):
        meshes.append((gt[i], faces))
        scalars.append(None)
        scale = f" (colour: 0 to {1000 * clim[1]:.0f} mm)" if i == 0 and clim[1] < 1 else ""
        labels.append(f"ground truth{' · ' + titles[i] if titles else ''}{scale}")
        for name in reconstructions:
            meshes.append((aligned[name][i], faces))
            scalars.append(errors[name][i])
            labels.append(f"{name}: mean {1000 * errors[name][i].mean():.1f} mm" if clim[1] < 1 else name)
    ncols = 1 + len(reconstructions)
    return plot_meshes(
        meshes,
        scalars,
        labels,
        cmap="magma_r",
        clim=clim,
        ncols=ncols,
        camera=camera,
        zoom=zoom,
        window_size=(330 * ncols, 360 * len(gt)),
    )


def plot_mapped_reconstructions(surface_maps, reconstructions: dict, truth, *, camera="xz", zoom=1.2):
    """Shapes given on another triangulation, their maps onto the base, and their reconstructions; one per row.

    Columns: each mesh (e.g. 5k vertices) painted with a function of the base carried through its map
    (left and right sides in opposite colours, deepening from feet to head), the base painted with
    that function (equal colours mark corresponding points: a mirrored map swaps blue and red), then
    each reconstruction coloured by its error against ``truth`` (as :func:`plot_reconstructions`).

    Parameters
    ----------
    surface_maps : list of N :class:`opnet.matching.SurfaceMap` onto one base.
    reconstructions : dict name → (N, n_base, 3) vertices on the base's triangulation.
    truth : (N, n_base, 3) the shapes on the base's triangulation.
    """
    from .matching import SurfaceMap

    if not surface_maps or not all(isinstance(sm, SurfaceMap) for sm in surface_maps):
        raise TypeError("surface_maps must be a non-empty list of opnet.matching.SurfaceMap.")
    if not reconstructions:
        raise ValueError("reconstructions is empty: give at least one name → (N, n_base, 3) array.")
    truth = np.asarray(truth, dtype=np.float64)
    base = surface_maps[0].base.mesh
    x, z = base.vertices[:, 0], base.vertices[:, 2]  # +x the body's left, +z up
    painted = np.sign(x) * (1 + (z - z.min()) / np.ptp(z))
    errors = {name: _aligned_errors(r, truth) for name, r in reconstructions.items()}
    top = max(float(e.max()) for _, e in errors.values())
    meshes, scalars, titles, cmaps, clims = [], [], [], [], []
    for i, sm in enumerate(surface_maps):
        meshes += [sm.mesh, base]
        scalars += [sm.to_base @ painted, painted]
        titles += [
            f"input ({sm.mesh.n_vertices} vertices), through its map",
            f"the base ({base.n_vertices} vertices): the map's target",
        ]
        cmaps += ["coolwarm", "coolwarm"]
        clims += [(-2.0, 2.0), (-2.0, 2.0)]
        for name, (aligned, err) in errors.items():
            meshes.append((aligned[i], base.faces))
            scalars.append(err[i])
            scale = f" (0 to {1000 * top:.0f})" if i == 0 else ""
            titles.append(f"{name}: mean {1000 * err[i].mean():.1f} mm{scale}")
            cmaps.append("magma_r")
            clims.append((0.0, top))
    ncols = 2 + len(reconstructions)
    return plot_meshes(
        meshes,
        scalars,
        titles,
        cmaps=cmaps,
        clims=clims,
        ncols=ncols,
        camera=camera,
        zoom=zoom,
        window_size=(330 * ncols, 360 * len(surface_maps)),
    )


def _aligned_errors(shapes, truth):
    """``shapes`` rigidly aligned onto ``truth`` (both ``(N, n, 3)``) and their per-vertex distances ``(N, n)``."""
    from .metrics import rigid_align

    truth = np.asarray(truth, dtype=np.float64)
    aligned = rigid_align(np.asarray(shapes, np.float64), truth)
    return aligned, np.linalg.norm(aligned - truth, axis=-1)


def plot_interpolations(paths: dict, faces, t, *, truth=None, columns: int = 6, clim=None, camera="xz", zoom=1.2):
    """Interpolation strips: one row per method, ``columns`` evenly spaced steps of the path from left to right.

    ``paths``: name → ``(T, n, 3)`` shapes at parameters ``t`` ``(T,)``. With ``truth`` ``(T, n, 3)`` (the true
    in-between shapes) a first row shows it and every method's shapes are aligned onto it and coloured by their
    distance to it (shared range ``clim``, default 0 to the largest error shown; metres → mm in the captions).
    """
    t = np.asarray(t, dtype=np.float64)
    cols = np.unique(np.linspace(0, len(t) - 1, min(columns, len(t))).round().astype(int))
    rows = ({"ground truth": truth} if truth is not None else {}) | dict(paths)
    meshes, scalars, titles, errors = [], [], [], {}
    if truth is not None:
        errors = {name: _aligned_errors(np.asarray(p)[cols], np.asarray(truth)[cols]) for name, p in paths.items()}
    vmax = max((float(e.max()) for _, e in errors.values()), default=1.0)
    clim = clim or (0.0, vmax)
    for name, p in rows.items():
        for j, c in enumerate(cols):
            if name in errors:
                meshes.append((errors[name][0][j], faces))
                scalars.append(errors[name][1][j])
            else:
                meshes.append((np.asarray(p)[c], faces))
                scalars.append(None)
            head = f"{name}\n" if j == 0 else "\n"
            err = f", {1000 * errors[name][1][j].mean():.1f} mm" if name in errors and clim[1] < 1 else ""
            titles.append(f"{head}t = {t[c]:.2f}{err}")
    return plot_meshes(
        meshes,
        scalars,
        titles,
        cmap="magma_r",
        clim=clim,
        ncols=len(cols),
        camera=camera,
        zoom=zoom,
        window_size=(240 * len(cols), 300 * len(rows)),
    )


def plot_analogies(A, B, C, results: dict, faces, *, truth=None, clim=None, camera="xz", zoom=1.2):
    """Analogy grids ``A : B :: C : X``: one row per question, its three shapes, the true ``X`` (optional) and each
    method's ``X``, coloured by its distance to the true one when given (as :func:`plot_reconstructions`).

    ``A``, ``B``, ``C``: ``(N, n, 3)``; ``results``: name → ``(N, n, 3)``; ``truth``: ``(N, n, 3)`` or ``None``.
    """
    A, B, C = (np.asarray(x, np.float64) for x in (A, B, C))
    errors = {name: _aligned_errors(x, truth) for name, x in results.items()} if truth is not None else {}
    vmax = max((float(e.max()) for _, e in errors.values()), default=1.0)
    clim = clim or (0.0, vmax)
    meshes, scalars, titles = [], [], []
    for i in range(len(A)):
        shown = [("A", A[i], None), ("B", B[i], None), ("C", C[i], None)]
        shown += [("true X", np.asarray(truth)[i], None)] if truth is not None else []
        for name, X in results.items():
            if name in errors:
                shown.append(
                    (
                        f"{name}: {1000 * errors[name][1][i].mean():.1f} mm" if clim[1] < 1 else name,
                        errors[name][0][i],
                        errors[name][1][i],
                    )
                )
            else:
                shown.append((name, np.asarray(X)[i], None))
        for title, V, err in shown:
            meshes.append((V, faces))
            scalars.append(err)
            titles.append(title if i == 0 or err is not None else "")
    ncols = len(meshes) // len(A)
    return plot_meshes(
        meshes,
        scalars,
        titles,
        cmap="magma_r",
        clim=clim,
        ncols=ncols,
        camera=camera,
        zoom=zoom,
        window_size=(240 * ncols, 300 * len(A)),
    )


def plot_history(histories: dict, *, ax=None):
    """Training curves: train loss (dashed) and validation ``d_R`` (solid), ×10⁻⁴, per epoch, log scale.

    ``histories``: dict label → the history returned by :func:`opnet.train.fit`. Returns the figure.
    """
    plt = require("matplotlib.pyplot", "opnet.plotting")

    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 3.6))
    else:
        fig = ax.figure
    for i, (label, hist) in enumerate(histories.items()):
        epochs = [h["epoch"] for h in hist]
        color = f"C{i}"
        ax.plot(epochs, [1e4 * h["train_loss"] for h in hist], "--", color=color, alpha=0.7)
        ax.plot(epochs, [1e4 * h["val_d_R"] for h in hist], "-", color=color, label=label)
    ax.set_yscale("log")
    ax.set_xlabel("epoch")
    ax.set_ylabel("d_R (×10⁻⁴)")
    ax.set_title("train loss (dashed) and validation d_R (solid)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_refinement_curves(curves: dict, *, axes=None):
    """Operator mismatch and ``d_R`` (×10⁻⁴) against the optimisation step, one line per run.

    ``curves``: name → dict with ``step``, ``mismatch`` and ``d_R`` (equal-length sequences, e.g. the means over
    the shapes recorded by :func:`opnet.reconstruct`'s ``callback``). Returns the matplotlib figure.
    """
    plt = require("matplotlib.pyplot", "opnet.plotting")

    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for name, c in curves.items():
        axes[0].plot(c["step"], c["mismatch"], label=name)
        axes[1].plot(c["step"], 1e4 * np.asarray(c["d_R"]), label=name)
    axes[0].set(yscale="log", xlabel="step", ylabel="relative operator mismatch", title="what is minimised")
    axes[1].set(yscale="log", xlabel="step", ylabel="d_R (×10⁻⁴)", title="what we want")
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
    axes[1].legend(fontsize=8)
    axes[0].figure.tight_layout()
    return axes[0].figure


def plot_ablation(table, rows, columns, *, title="d_R on test (×10⁻⁴)", ax=None):
    """Heat map of an ablation table ``(len(rows), len(columns))`` with its values written in the cells."""
    plt = require("matplotlib.pyplot", "opnet.plotting")

    table = np.asarray(table, dtype=float)
    if ax is None:
        fig, ax = plt.subplots(figsize=(1.1 * len(columns) + 2, 0.6 * len(rows) + 1.5))
    else:
        fig = ax.figure
    im = ax.imshow(table, cmap="viridis_r", aspect="auto")
    lo, hi = np.nanmin(table), np.nanmax(table)
    for (i, j), v in np.ndenumerate(table):
        if np.isfinite(v):  # white on the dark (high) end of viridis_r, black on the light end
            dark = hi > lo and (v - lo) / (hi - lo) > 0.55
            ax.text(j, i, f"{v:.3g}", ha="center", va="center", color="white" if dark else "black", fontsize=9)
    ax.set_xticks(range(len(columns)), columns)
    ax.set_yticks(range(len(rows)), rows)
    ax.set_title(title)
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    fig.tight_layout()
    return fig
