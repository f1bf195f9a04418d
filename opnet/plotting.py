"""Figures: meshes with scalar fields (pyvista, static images) and operators as heat maps (matplotlib)."""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

from ._extras import require
from .mesh import Mesh

__all__ = [
    "headless",
    "use_static_backend",
    "to_pyvista",
    "side_view",
    "plot_meshes",
    "plot_operators",
    "plot_reconstructions",
    "plot_mapped_reconstructions",
    "error_scale",
    "error_top",
    "plot_history",
    "plot_refinement_curves",
    "plot_ablation",
    "plot_interpolations",
    "plot_analogies",
    "SPLIT_COLOURS",
    "plot_split_matrix",
    "plot_shape_variety",
    "plot_operator_drift",
    "plot_error_histograms",
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


def side_view(collection) -> str:
    """The pyvista camera position (``camera=`` of the plots here) that shows ``collection``'s shapes from the side:
    its profile's :attr:`~opnet.data.profiles.Profile.view` (``"zy"`` for the animals, y up; ``"xz"``, z up, for the
    others).
    """
    from .data.profiles import profile_of

    return profile_of(collection.meta.get("name")).view


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
    scalar_bar: str | None = None,
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
    scalar_bar : str, optional
        The title (with the unit) of a colour bar, drawn beside the last mesh that has scalars: give the meshes
        that share its colour map one ``clim`` so that it reads for all of them.
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
    bar = max((i for i, s in enumerate(scalars) if s is not None), default=None) if scalar_bar else None
    for i, (m, s, t, cmap, clim) in enumerate(zip(meshes, scalars, titles, cmaps, clims)):
        plotter.subplot(i // ncols, i % ncols)
        kw = dict(smooth_shading=True, show_scalar_bar=i == bar)
        if i == bar:
            kw["scalar_bar_args"] = dict(
                title=scalar_bar, color="black", vertical=True, position_x=0.78, position_y=0.15, width=0.1,
                height=0.6, n_labels=4, fmt="%.3g", title_font_size=12, label_font_size=11,
            )  # fmt: skip
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
        aligned onto the ground truth and painted with its per-vertex distance to it (shared colour range
        ``clim`` in the input's unit, default 0 to :func:`error_top` of the errors shown; painted in mm for
        shapes in metres, :func:`error_scale`), with a colour bar.
    faces : (m, 3) shared triangles.
    titles : list of N str, optional, a caption per row (e.g. the shape's sequence).
    """
    gt = np.asarray(gt, dtype=np.float64)
    aligned, errors = {}, {}
    for name, r in reconstructions.items():
        aligned[name], errors[name] = aligned_errors(r, gt)
    vmax = error_top(errors.values()) if clim is None else None
    clim = clim or (0.0, vmax)
    factor, bar = error_scale(clim[1])
    meshes, scalars, labels = [], [], []
    for i in range(len(gt)):
        meshes.append((gt[i], faces))
        scalars.append(None)
        labels.append(f"ground truth{' · ' + titles[i] if titles else ''}")
        for name in reconstructions:
            meshes.append((aligned[name][i], faces))
            scalars.append(factor * errors[name][i])
            labels.append(f"{name}: mean {factor * errors[name][i].mean():.1f} mm" if factor != 1 else name)
    ncols = 1 + len(reconstructions)
    return plot_meshes(
        meshes,
        scalars,
        labels,
        cmap="magma_r",
        clim=(factor * clim[0], factor * clim[1]),
        ncols=ncols,
        camera=camera,
        zoom=zoom,
        window_size=(330 * ncols, 360 * len(gt)),
        scalar_bar=bar,
    )


def plot_mapped_reconstructions(surface_maps, reconstructions: dict, truth, *, labels=None, camera="xz", zoom=1.2):
    """Shapes given on another triangulation, their maps onto the base, and their reconstructions; one per row.

    Columns: each mesh (e.g. 5k vertices) painted with a function of the base carried through its map
    (left and right sides in opposite colours, deepening from feet to head), the base painted with
    that function (equal colours mark corresponding points: a mirrored map swaps blue and red), then
    each reconstruction coloured by its error against ``truth`` (as :func:`plot_reconstructions`).

    Parameters
    ----------
    surface_maps : list of N :class:`opnet.matching.SurfaceMap` onto one base.
    reconstructions : dict name → (N, n_base, 3) vertices on the base's triangulation (or on the mesh ``labels``
        gives for that name).
    truth : (N, n_base, 3) the shapes on the base's triangulation.
    labels : dict name → ``(truth (N, n, 3), faces (m, 3))``, optional: for a reconstruction on another mesh than the
        base's (a network trained with finer labels), the shapes it is measured against and that mesh's triangles.
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
    labels = labels or {}
    unknown = set(labels) - set(reconstructions)
    if unknown:
        raise ValueError(f"labels names {sorted(unknown)}, which are not reconstructions ({list(reconstructions)}).")
    errors = {name: aligned_errors(r, labels.get(name, (truth,))[0]) for name, r in reconstructions.items()}
    top = error_top(e for _, e in errors.values())
    factor, bar = error_scale(top)
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
            meshes.append((aligned[i], labels[name][1] if name in labels else base.faces))
            scalars.append(factor * err[i])
            titles.append(f"{name}: mean {1000 * err[i].mean():.1f} mm")
            cmaps.append("magma_r")
            clims.append((0.0, factor * top))
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
        scalar_bar=bar,
    )


def error_scale(top: float) -> tuple[float, str]:
    """How the error renders paint a distance whose colour range ends at ``top``: ``(factor, colour-bar title)``,
    millimetres for shapes in metres (``top < 1``), else the input's own unit.
    """
    return (1000.0, "error (mm)") if top < 1 else (1.0, "error")


def error_top(errors) -> float:
    """The top of the error renders' shared colour range: the 98th percentile of all the per-vertex errors shown
    (each an array), so that one failed panel does not wash out the others (its worst vertices saturate); 1.0 when
    there are none.
    """
    values = [np.ravel(e) for e in errors]
    top = float(np.nanpercentile(np.concatenate(values), 98)) if values else 1.0
    return top if np.isfinite(top) and top > 0 else 1.0  # all NaN (a diverged network) or all exact


def aligned_errors(shapes, truth):
    """``shapes`` rigidly aligned onto ``truth`` (both ``(N, n, 3)``) and their per-vertex distances ``(N, n)``."""
    from .metrics import rigid_align

    truth = np.asarray(truth, dtype=np.float64)
    aligned = rigid_align(np.asarray(shapes, np.float64), truth)
    return aligned, np.linalg.norm(aligned - truth, axis=-1)


def plot_interpolations(paths: dict, faces, t, *, truth=None, columns: int = 6, clim=None, camera="xz", zoom=1.2):
    """Interpolation strips: one row per method, ``columns`` evenly spaced steps of the path from left to right.

    ``paths``: name → ``(T, n, 3)`` shapes at parameters ``t`` ``(T,)``. With ``truth`` ``(T, n, 3)`` (the true
    in-between shapes) a first row shows it and every method's shapes are aligned onto it and coloured by their
    distance to it (shared range ``clim``, default 0 to :func:`error_top` of the errors shown; in mm for shapes in
    metres, with a colour bar).
    """
    t = np.asarray(t, dtype=np.float64)
    cols = np.unique(np.linspace(0, len(t) - 1, min(columns, len(t))).round().astype(int))
    rows = ({"ground truth": truth} if truth is not None else {}) | dict(paths)
    meshes, scalars, titles, errors = [], [], [], {}
    if truth is not None:
        errors = {name: aligned_errors(np.asarray(p)[cols], np.asarray(truth)[cols]) for name, p in paths.items()}
    vmax = error_top(e for _, e in errors.values())
    clim = clim or (0.0, vmax)
    factor, bar = error_scale(clim[1])
    for name, p in rows.items():
        for j, c in enumerate(cols):
            if name in errors:
                meshes.append((errors[name][0][j], faces))
                scalars.append(factor * errors[name][1][j])
            else:
                meshes.append((np.asarray(p)[c], faces))
                scalars.append(None)
            head = f"{name}\n" if j == 0 else "\n"
            err = f", {factor * errors[name][1][j].mean():.1f} mm" if name in errors and factor != 1 else ""
            titles.append(f"{head}t = {t[c]:.2f}{err}")
    return plot_meshes(
        meshes,
        scalars,
        titles,
        cmap="magma_r",
        clim=(factor * clim[0], factor * clim[1]),
        ncols=len(cols),
        camera=camera,
        zoom=zoom,
        window_size=(240 * len(cols), 300 * len(rows)),
        scalar_bar=bar if errors else None,
    )


def plot_analogies(A, B, C, results: dict, faces, *, truth=None, clim=None, camera="xz", zoom=1.2):
    """Analogy grids ``A : B :: C : X``: one row per question, its three shapes, the true ``X`` (optional) and each
    method's ``X``, coloured by its distance to the true one when given (as :func:`plot_reconstructions`).

    ``A``, ``B``, ``C``: ``(N, n, 3)``; ``results``: name → ``(N, n, 3)``; ``truth``: ``(N, n, 3)`` or ``None``.
    """
    A, B, C = (np.asarray(x, np.float64) for x in (A, B, C))
    errors = {name: aligned_errors(x, truth) for name, x in results.items()} if truth is not None else {}
    vmax = error_top(e for _, e in errors.values())
    clim = clim or (0.0, vmax)
    factor, bar = error_scale(clim[1])
    meshes, scalars, titles = [], [], []
    for i in range(len(A)):
        shown = [("A", A[i], None), ("B", B[i], None), ("C", C[i], None)]
        shown += [("true X", np.asarray(truth)[i], None)] if truth is not None else []
        for name, X in results.items():
            if name in errors:
                shown.append(
                    (
                        f"{name}: {factor * errors[name][1][i].mean():.1f} mm" if factor != 1 else name,
                        errors[name][0][i],
                        factor * errors[name][1][i],
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
        clim=(factor * clim[0], factor * clim[1]),
        ncols=ncols,
        camera=camera,
        zoom=zoom,
        window_size=(240 * ncols, 300 * len(A)),
        scalar_bar=bar if errors else None,
    )


def plot_history(histories: dict, *, ax=None):
    """Training curves: train loss (dashed) and validation ``d_R`` (solid), ×10⁻⁴, per epoch, log scale.

    ``histories``: dict label → the history returned by :func:`opnet.train.fit`, or a list of them (one network
    trained with several seeds: each seed's curves in the label's colour, so that their spread shows; the label says
    how many). Returns the figure.
    """
    fig, ax = _figure_and_axes(ax, (7, 3.6))
    for i, (label, hist) in enumerate(histories.items()):
        seeds = [hist] if not hist or isinstance(hist[0], Mapping) else list(hist)  # a history: a list of dicts
        color = f"C{i}"
        for s, one in enumerate(seeds):
            epochs = [h["epoch"] for h in one]
            ax.plot(epochs, [1e4 * h["train_loss"] for h in one], "--", color=color, alpha=0.7, lw=0.8)
            name = (f"{label} ({len(seeds)} seeds)" if len(seeds) > 1 else label) if s == 0 else None
            ax.plot(epochs, [1e4 * h["val_d_R"] for h in one], "-", color=color, label=name, lw=1.2)
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


def plot_ablation(table, rows, columns, *, title="d_R on test (×10⁻⁴)", ax=None, half_widths=None):
    """Heat map of an ablation table ``(len(rows), len(columns))`` with its values written in the cells;
    ``half_widths`` (same shape, NaN where unknown): each cell's interval, written ``± h`` under its value.
    """
    table = np.asarray(table, dtype=float)
    half = np.full_like(table, np.nan) if half_widths is None else np.asarray(half_widths, dtype=float)
    if half.shape != table.shape:
        raise ValueError(f"half_widths must have the table's shape {table.shape}, got {half.shape}.")
    fig, ax = _figure_and_axes(ax, (1.1 * len(columns) + 2, 0.6 * len(rows) + 1.5))
    im = ax.imshow(table, cmap="viridis_r", aspect="auto")
    lo, hi = np.nanmin(table), np.nanmax(table)
    for (i, j), v in np.ndenumerate(table):
        if np.isfinite(v):  # white on the dark (high) end of viridis_r, black on the light end
            dark = hi > lo and (v - lo) / (hi - lo) > 0.55
            text = f"{v:.3g}" + (f"\n± {half[i, j]:.2g}" if np.isfinite(half[i, j]) else "")
            ax.text(j, i, text, ha="center", va="center", color="white" if dark else "black", fontsize=9)
    ax.set_xticks(range(len(columns)), columns)
    ax.set_yticks(range(len(rows)), rows)
    ax.set_title(title)
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    fig.tight_layout()
    return fig


#: The colour of each split in :func:`plot_split_matrix` and :func:`plot_shape_variety`.
SPLIT_COLOURS = {"train": "#90a4ae", "val": "#ffb74d", "test": "#e53935", "test_subjects": "#8e24aa"}


def _figure_and_axes(ax, figsize):
    """``(figure, ax)``: a new figure of ``figsize`` inches when ``ax`` is None, else ``ax``'s own."""
    plt = require("matplotlib.pyplot", "opnet.plotting")

    if ax is None:
        fig, ax = plt.subplots(figsize=figsize)
        return fig, ax
    return ax.figure, ax


def _motions(collection) -> np.ndarray:
    """``(N,)`` str: each shape's motion, ``params["motion"]``, else its sub-collection's name after the last ``/``."""
    if "motion" in collection.params:
        return np.asarray(collection.params["motion"]).astype(str)
    return np.array([str(s).rpartition("/")[2] for s in collection.subcollection])


def plot_split_matrix(collection, *, motions=None, ax=None):
    """Which (subject, motion) sequences each split holds: one row per subject, one column per motion.

    Parameters
    ----------
    collection : opnet.data.Collection
        Rows: ``collection.subjects()``. Columns: the motions of ``params["motion"]`` ``(N,)`` (for a collection
        without one, the part of each sub-collection's name after its last ``/``).
    motions : list of str, optional
        The columns, in this order (default: every motion, in the order the collection first lists them).
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).

    Returns
    -------
    matplotlib.figure.Figure
        Cell ``(subject, motion)`` holds the split of that sequence's shapes as its index in ``SPLIT_COLOURS``
        (``0`` train, ``1`` val, ``2`` test, ``3`` test_subjects; NaN, blank, where the subject has no such
        sequence), coloured as ``SPLIT_COLOURS`` says, with a legend.
    """
    plt = require("matplotlib.pyplot", "opnet.plotting")

    names = collection.subjects()
    motion = _motions(collection)
    columns = list(dict.fromkeys(motion.tolist())) if motions is None else list(motions)
    codes = {split: c for c, split in enumerate(SPLIT_COLOURS)}
    row, col = {s: i for i, s in enumerate(names)}, {m: j for j, m in enumerate(columns)}
    table = np.full((len(names), len(columns)), np.nan)
    for s, m, split in zip(collection.subject.tolist(), motion.tolist(), collection.split.tolist()):
        if m in col:
            table[row[s], col[m]] = codes[split]
    fig, ax = _figure_and_axes(ax, (max(4.0, 0.45 * len(columns) + 3.5), 0.3 * len(names) + 1.6))
    cmap = plt.matplotlib.colors.ListedColormap(list(SPLIT_COLOURS.values()))
    ax.imshow(table, cmap=cmap, vmin=-0.5, vmax=len(codes) - 0.5, aspect="auto", interpolation="nearest")
    ax.set_xticks(range(len(columns)), columns, rotation=60, ha="right")
    ax.set_yticks(range(len(names)), names)
    ax.legend(
        handles=[plt.matplotlib.patches.Patch(color=c, label=s) for s, c in SPLIT_COLOURS.items()],
        bbox_to_anchor=(1.01, 1),
        loc="upper left",
    )
    ax.set_title("which (subject, motion) sequences are held out")
    fig.tight_layout()
    return fig


def plot_shape_variety(
    collection,
    *,
    parameters: str = "phenotypes",
    names=None,
    splits=("train", "test", "test_subjects"),
    bins: int = 15,
    scale: float = 100.0,
    unit: str = "cm",
):
    """Histograms of how a collection varies: each subject parameter, and every shape's distance to the base.

    Parameters
    ----------
    collection : opnet.data.Collection
    parameters : str
        The key of ``collection.params`` holding a ``(N, p)`` array of per-shape subject parameters (default the
        ``anny`` phenotypes in [0, 1]); one panel per column, counting each subject once (its first shape's
        values). Skipped when the collection has no such entry.
    names : list of p str, optional
        The panels' titles (default: :data:`opnet.data.subjects.PHENOTYPES` for six phenotypes, else
        ``"phenotypes[j]"``).
    splits : tuple of str
        The splits whose distances to the base are drawn, one translucent histogram each, in ``SPLIT_COLOURS``.
    bins : int
        Bins per histogram.
    scale, unit : float, str
        The distances' unit: the collection's length unit × ``scale`` (metres × 100 = cm).

    Returns
    -------
    matplotlib.figure.Figure
        ``p + 1`` panels; the last one is ``√d_R`` (eq. 9) of every shape of ``splits`` against the base, the
        root-mean-square vertex distance after rigid alignment, in ``unit``.
    """
    from .data.subjects import PHENOTYPES
    from .metrics import d_R

    plt = require("matplotlib.pyplot", "opnet.plotting")

    values = collection.params.get(parameters)
    if values is not None:
        first = np.unique(collection.subject, return_index=True)[1]  # one row per subject
        values = np.asarray(values, dtype=float).reshape(len(collection), -1)[first]
    p = 0 if values is None else values.shape[1]
    if names is None:
        names = (
            PHENOTYPES
            if parameters == "phenotypes" and p == len(PHENOTYPES)
            else [f"{parameters}[{j}]" for j in range(p)]
        )
    fig, axes = plt.subplots(
        1, p + 1, figsize=(2.3 * p + 3.6, 2.8), squeeze=False, gridspec_kw=dict(width_ratios=[1] * p + [1.6])
    )
    axes = axes[0]
    for j in range(p):
        axes[j].hist(values[:, j], bins=bins, color="#607d8b")
        axes[j].set_title(names[j])
    for ax in axes:
        ax.yaxis.set_major_locator(plt.matplotlib.ticker.MaxNLocator(integer=True))
    axes[0].set_ylabel("subjects" if p else "shapes")
    base = collection.base_basis.mesh.vertices
    chunks = np.array_split(np.arange(len(collection)), max(1, len(collection) // 1024))  # bounded float64 copies
    rms = np.concatenate(
        [
            scale * np.sqrt(d_R(np.broadcast_to(base, (len(c), *base.shape)), collection.vertices[c].astype(float)))
            for c in chunks
        ]
    )
    shown = np.isin(collection.split, splits)
    edges = np.histogram_bin_edges(rms[shown] if shown.any() else rms, bins=bins)  # shared by the splits
    for split in splits:
        axes[-1].hist(
            rms[collection.split == split], bins=edges, alpha=0.6, color=SPLIT_COLOURS.get(split), label=split
        )
    axes[-1].set_title(f"RMS distance to base ({unit})")
    if p:
        axes[-1].set_ylabel("shapes")
    axes[-1].legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_operator_drift(collection, indices, *, x=None, xlabel=None, ax=None):
    """How far each shape difference is from the identity along a sequence of shapes (e.g. one motion).

    Parameters
    ----------
    collection : opnet.data.Collection
        Its ``operators`` ``(N, C, k, k)``, one line per channel of ``collection.channels``.
    indices : (T,) int array
        The shapes, in order (e.g. ``collection.sequence("subject00", "arm_raise")``).
    x : (T,) array, optional
        Their abscissae (default: ``params["frame"]`` when the collection has it, else ``0 … T − 1``).
    xlabel : str, optional
        The abscissa's label (default ``"frame"``, or ``"shape"`` without frames).
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
        One line per channel: ``‖D − I‖_F`` on the non-constant block (the operator without its first row and
        column, those of the constant function), dimensionless.
    """
    indices = np.asarray(indices)
    frames = "frame" in collection.params
    if x is None:
        x = np.asarray(collection.params["frame"])[indices] if frames else np.arange(len(indices))
    D = np.asarray(collection.operators[indices], dtype=np.float64)[:, :, 1:, 1:]
    drift = np.linalg.norm(D - np.eye(D.shape[-1]), axis=(-2, -1))  # (T, C)
    fig, ax = _figure_and_axes(ax, (6, 3.2))
    for c, channel in enumerate(collection.channels):
        ax.plot(x, drift[:, c], "o-", label=channel)
    if np.issubdtype(np.asarray(x).dtype, np.integer):  # frames: no ticks between them
        ax.xaxis.set_major_locator(require("matplotlib.ticker", "opnet.plotting").MaxNLocator(integer=True))
    ax.set_xlabel(xlabel or ("frame" if frames else "shape"))
    ax.set_ylabel("‖D − I‖ (non-constant block)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig


def plot_error_histograms(
    errors: dict,
    *,
    label: str = "d_R on test (×10⁻⁴ m²)",
    scale: float = 1e4,
    log: bool = True,
    bins: int = 30,
    ax=None,
):
    """Overlaid histograms of per-shape errors, one per method, on shared bins.

    Parameters
    ----------
    errors : dict str → (N_m,) array
        Per-shape errors of each method, e.g. ``{"OperatorNet": err["d_R"], "NN": err_nn["d_R"]}`` with ``d_R``
        in m² (:func:`opnet.evaluate.shape_errors`).
    label : str
        The abscissa's label, with the unit after ``scale``.
    scale : float
        Multiplies the errors before binning (1e4: m² → the paper's ×10⁻⁴ m²).
    log : bool
        Logarithmic bins and axis (errors spread over orders of magnitude); non-positive errors are left out.
    bins : int
        Number of bins, shared by all methods.
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
        One translucent histogram per method (in order, colours ``C0``, ``C1``, …) counting shapes, with a legend.
    """
    if not errors:
        raise ValueError("errors is empty: give at least one name → (N,) array.")
    scaled = {name: scale * np.asarray(e, dtype=np.float64).ravel() for name, e in errors.items()}
    kept = {name: np.isfinite(e) & (e > 0 if log else True) for name, e in scaled.items()}
    dropped = {name: int((~k).sum()) for name, k in kept.items()}  # NaN (e.g. d_V of open meshes), and ≤ 0 on log
    scaled = {name: e[kept[name]] for name, e in scaled.items()}
    pooled = np.concatenate(list(scaled.values()))
    if pooled.size == 0:
        raise ValueError("no finite errors to draw" + (" (log=True leaves out the non-positive ones)." if log else "."))
    lo, hi = float(pooled.min()), float(pooled.max())
    if log:
        lo, hi = (lo / 1.5, hi * 1.5) if lo == hi else (lo, hi)
        edges = np.logspace(np.log10(lo), np.log10(hi), bins + 1)
        edges[[0, -1]] = lo, hi  # exactly: 10 ** log10(x) may round below the largest error and drop it
    else:
        lo, hi = (lo - 0.5, hi + 0.5) if lo == hi else (lo, hi)
        edges = np.linspace(lo, hi, bins + 1)
    fig, ax = _figure_and_axes(ax, (7, 3))
    for i, (name, e) in enumerate(scaled.items()):
        left_out = f", {dropped[name]} left out" if dropped[name] else ""
        ax.hist(e, bins=edges, alpha=0.6, color=f"C{i}", label=f"{name} (median {np.median(e):.3g}{left_out})")
    if log:
        ax.set_xscale("log")
    ax.set_xlabel(label)
    ax.set_ylabel("shapes")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
