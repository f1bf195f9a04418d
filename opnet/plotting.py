"""Figures: meshes with scalar fields (pyvista, static images) and operators as heat maps (matplotlib)."""
from __future__ import annotations

import os

import numpy as np

from .mesh import Mesh

__all__ = ["use_static_backend", "to_pyvista", "plot_meshes", "plot_operators"]


def use_static_backend(window_size=(900, 300)) -> None:
    """Render pyvista figures as static PNG images (headless through EGL when there is no display).

    Call it at the top of a notebook so that readers and the test-suite see the same images.
    """
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    pv.OFF_SCREEN = True
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
    import pyvista as pv

    v, f = (mesh.vertices, mesh.faces) if isinstance(mesh, Mesh) else mesh
    f = np.asarray(f)
    return pv.PolyData(np.asarray(v), np.hstack([np.full((len(f), 1), 3), f]).ravel())


def plot_meshes(meshes, scalars=None, titles=None, *, cmap="coolwarm", clim=None, ncols=None, camera="yz", zoom=1.0,
                window_size=None):
    """A pyvista plotter with one mesh per subplot (call ``.show()`` on it, or ``.screenshot(path)``).

    Parameters
    ----------
    meshes : list of Mesh or (vertices, faces)
    scalars : list of (n,) arrays or None, optional
        A vertex function painted on each mesh (``None`` for a plain surface).
    titles : list of str, optional
    cmap, clim : colormap name and (min, max); ``clim`` defaults to each field's own range.
    ncols : subplots per row (default: all in one row).
    camera : str, a pyvista camera position such as ``"yz"`` or ``"xy"``.
    """
    import pyvista as pv

    meshes = list(meshes)
    scalars = [None] * len(meshes) if scalars is None else list(scalars)
    titles = [None] * len(meshes) if titles is None else list(titles)
    if not len(meshes) == len(scalars) == len(titles):
        raise ValueError("meshes, scalars and titles must have the same length.")
    ncols = ncols or len(meshes)
    nrows = -(-len(meshes) // ncols)
    size = window_size or (300 * ncols, 380 * nrows)
    plotter = pv.Plotter(shape=(nrows, ncols), window_size=list(size), border=False, off_screen=True)
    for i, (m, s, t) in enumerate(zip(meshes, scalars, titles)):
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


def plot_operators(operators, titles=None, *, vmax=None, cmap="RdBu_r"):
    """Heat maps of ``k × k`` operators side by side; returns the matplotlib figure.

    The colour range is symmetric about 0 (``vmax`` defaults to each operator's largest
    absolute entry), so positive and negative entries read alike.
    """
    import matplotlib.pyplot as plt

    operators = [np.asarray(D) for D in operators]
    titles = titles or [None] * len(operators)
    fig, axes = plt.subplots(1, len(operators), figsize=(3.3 * len(operators), 3.2), squeeze=False)
    for ax, D, t in zip(axes[0], operators, titles):
        m = vmax or np.abs(D).max()
        im = ax.imshow(D, cmap=cmap, vmin=-m, vmax=m)
        ax.set_title(t)
        ax.set_xticks([])
        ax.set_yticks([])
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    fig.tight_layout()
    return fig
