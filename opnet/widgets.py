"""Interactive interpolation and analogy (ipywidgets, in JupyterLab), with a static fallback.

::

    explorer = opnet.widgets.interpolation_explorer(ds, methods)   # a slider for t, dropdowns, a method selector
    opnet.widgets.show(explorer)                                    # the widget, or a picture of its current state

Each explorer renders its shapes side by side with pyvista off screen into an ``ipywidgets.Image`` that updates
when a control changes. Where no kernel drives the widgets — a notebook executed by ``make run`` (its HTML) or by
the tests (nbval) — :func:`show` displays that image instead, so the page reads complete; those commands set
``OPNET_STATIC_WIDGETS=1``. ``methods`` are :class:`opnet.apps.ShapeAlgebra` objects.
"""

from __future__ import annotations

import io
import os

import numpy as np

from ._extras import require

__all__ = ["interactive", "show", "render_png", "interpolation_explorer", "analogy_explorer", "shape_labels"]


def interactive() -> bool:
    """Whether :func:`show` displays live widgets: yes unless ``OPNET_STATIC_WIDGETS`` is set to ``1``."""
    return os.environ.get("OPNET_STATIC_WIDGETS", "0") != "1"


def show(explorer) -> None:
    """Display an explorer: the live widget (:func:`interactive`), else a static PNG of its current state."""
    from IPython.display import Image, display

    if interactive():
        display(explorer)
    else:  # as JPEG, like the static backend's renders (a fraction of the PNG's size)
        import PIL.Image

        buf = io.BytesIO()
        PIL.Image.open(io.BytesIO(explorer.image.value)).convert("RGB").save(buf, format="jpeg", quality=90)
        display(Image(data=buf.getvalue(), format="jpeg"))


def render_png(
    meshes, faces, titles, scalars=None, *, clim=None, camera="xz", zoom=1.2, size=(220, 300), scalar_bar=None
) -> bytes:
    """Shapes ``(vertices (n, 3), ...)`` side by side, rendered off screen: PNG bytes (one row, ``size`` per shape).

    ``scalars``: a per-vertex field or ``None`` per shape, painted on a shared range ``clim`` (default 0 to the
    largest value), with a colour bar titled ``scalar_bar`` (its unit) when given.
    """
    import PIL.Image

    from .plotting import headless, plot_meshes

    headless()
    fields = [s for s in (scalars or []) if s is not None]
    clim = clim or ((0.0, max(float(np.max(s)) for s in fields)) if fields else None)
    plotter = plot_meshes(
        [(v, faces) for v in meshes],
        scalars,
        titles,
        cmap="magma_r",
        clim=clim,
        ncols=len(meshes),
        camera=camera,
        zoom=zoom,
        window_size=(size[0] * len(meshes), size[1]),
        scalar_bar=scalar_bar if fields else None,
    )
    img = plotter.screenshot(return_img=True)
    plotter.close()
    buf = io.BytesIO()
    PIL.Image.fromarray(img).save(buf, format="png")
    return buf.getvalue()


def shape_labels(collection, indices) -> dict:
    """Dropdown options: ``"subject03/walk, frame 2 (#17)"`` → index, for the collection's shapes ``indices``."""
    frames = collection.params.get("frame")
    return {
        f"{collection.subcollection[i]}" + (f", frame {frames[i]}" if frames is not None else "") + f" (#{i})": int(i)
        for i in indices
    }


def _far_pair(vertices, allowed=None) -> tuple[int, int]:
    """Positions ``(i, j)`` of the two shapes of ``vertices`` ``(N, n, 3)`` furthest apart (RMS over the vertices,
    without alignment: the pair a picture shows as most different); ``allowed[i, j]`` false excludes a pair.
    """
    X = np.asarray(vertices, dtype=np.float64).reshape(len(vertices), -1)
    sq = np.einsum("ij,ij->i", X, X)
    dist = sq[:, None] + sq[None, :] - 2 * X @ X.T  # (N, N) squared distances, N shapes (a few hundred at most)
    if allowed is not None:
        dist = np.where(allowed, dist, -np.inf)
    i, j = np.unravel_index(int(np.argmax(dist)), dist.shape)
    return int(i), int(j)


def _default_shapes(collection) -> dict:
    idx = np.concatenate([collection.indices("test"), collection.indices("test_subjects")])
    return shape_labels(collection, idx if len(idx) else np.arange(len(collection)))


def _with_errors(shapes: dict, truth):
    """Titles and per-vertex errors of shapes aligned onto ``truth`` (or plain shapes when there is none)."""
    from .plotting import aligned_errors

    names, meshes, scalars = [], [], []
    for name, V in shapes.items():
        if truth is None:
            names.append(name), meshes.append(V), scalars.append(None)
            continue
        A, err = aligned_errors(V, truth)
        names.append(f"{name}: {1000 * err.mean():.1f} mm"), meshes.append(A), scalars.append(err)
    return names, meshes, scalars


def interpolation_explorer(
    collection, methods, *, shapes: dict | None = None, steps: int = 11, camera="xz", start=None, end=None
):
    """A widget: dropdowns for the start and end shapes, a method selector, a slider for ``t``, and the shapes at
    ``t`` of every selected method side by side. Paths are computed once per (method, start, end) at ``steps``
    values of ``t``; the slider moves along them.

    ``shapes``: dropdown label → collection index (default: the ``test`` and ``test_subjects`` shapes,
    :func:`shape_labels`); ``start``, ``end``: initial labels (default: the two shapes of different sequences that
    differ most, so that the first picture shows a path that moves; given ``start``, the shape of another sequence
    furthest from it). All ``methods`` are selected at first; the picture shows the two ends beside them.
    Returns an ``ipywidgets.VBox`` with attributes ``image`` (the current render, for :func:`show`) and
    ``titles`` (the captions of the shapes shown).
    """
    w = require("ipywidgets", "opnet.widgets")

    shapes = shapes or _default_shapes(collection)
    labels = list(shapes)
    by_name = {m.name: m for m in methods}
    t = np.linspace(0, 1, steps)
    if start is None or end is None:  # the most different shapes of two sequences (no random poses)
        idx = np.array([shapes[label] for label in labels])
        sub, motion = collection.subcollection[idx], collection.params.get("motion", np.full(len(collection), ""))
        allowed = (sub[:, None] != sub[None, :]) & (motion[idx] != "random")[:, None] & (motion[idx] != "random")
        if start is not None:
            allowed &= (np.array(labels) == start)[:, None]
        if allowed.any():
            i, j = _far_pair(collection.vertices[idx], allowed)
            start, end = labels[i], labels[j]
        else:
            start, end = start or labels[0], labels[-1]
    first = w.Dropdown(options=labels, value=start, description="start")
    last = w.Dropdown(options=labels, value=end, description="end")
    chosen = w.SelectMultiple(options=list(by_name), value=tuple(by_name), description="methods", rows=len(by_name))
    slider = w.FloatSlider(value=0.5, min=0, max=1, step=1 / (steps - 1), description="t", continuous_update=False)
    image = w.Image(format="png")
    cache = {}

    def path(name):
        key = (name, first.value, last.value)
        if key not in cache:
            cache[key] = by_name[name].interpolate(shapes[first.value], shapes[last.value], t)
        return cache[key]

    def update(_=None):
        j = int(round(slider.value * (steps - 1)))
        shown = {f"{name}, t = {t[j]:.1f}": path(name)[j] for name in chosen.value}
        ends = (collection.vertices[shapes[first.value]], collection.vertices[shapes[last.value]])
        shown = {"start": ends[0], **shown, "end": ends[1]}  # the ends beside the methods' shapes at t
        box.titles = list(shown)
        image.value = render_png(list(shown.values()), collection.faces, box.titles, camera=camera)

    box = w.VBox([w.HBox([first, last]), w.HBox([chosen, slider]), image])
    box.image = image
    for control in (first, last, chosen, slider):
        control.observe(update, names="value")
    update()
    return box


def analogy_explorer(collection, methods, *, subjects=None, poses=None, camera="xz", initial=None):
    """A widget for ``A : B :: C : X`` with shapes made by the generator from a subject and a pose each.

    Dropdowns choose the subject and the pose of ``A``, ``B`` and ``C`` (subjects: the unseen ``test_subjects``;
    poses: the ``test`` shapes' poses, by default); a method selector chooses the methods whose ``X`` is shown.
    Where the analogy has a generated answer — the subject of ``X`` is ``C``'s when ``A`` and ``B`` share theirs,
    ``B``'s when ``A`` and ``C`` do, and likewise for the pose — the true ``X`` is shown and every method's ``X`` is
    coloured by its distance to it (mm, with a colour bar). ``initial``: ``(sA, pA, sB, pB, sC, pC)`` dropdown
    indices (default: a pose transfer between the two poses that differ most, so that the first picture shows a pose
    that moves). Returns an ``ipywidgets.VBox`` with attributes ``image`` (for :func:`show`), ``titles`` (the
    captions shown) and ``controls`` (the six dropdowns: A subject, A pose, B subject, ...).
    """
    w = require("ipywidgets", "opnet.widgets")

    from .apps import ground_truth_pool
    from .data.generators import generate_shapes

    subj, pose_idx, _ = ground_truth_pool(collection)
    own_poses = poses is not None
    subjects = subjects if subjects is not None else {f"unseen subject {i}": p for i, p in enumerate(subj)}
    poses = (
        poses
        if poses is not None
        else {label: collection.params["controls"][i] for label, i in shape_labels(collection, pose_idx).items()}
    )
    s_names, p_names = list(subjects), list(poses)
    by_name = {m.name: m for m in methods}
    if initial is None:  # A and C in one pose, B in the most different one: a pose transfer that shows
        p, q = (0, len(p_names) - 1) if own_poses or len(p_names) < 2 else _far_pair(collection.vertices[pose_idx])
        initial = (0, p, 0, q, min(1, len(s_names) - 1), p)
    boxes = []
    for role, k in zip("ABC", range(3)):
        boxes += [
            w.Dropdown(options=s_names, value=s_names[initial[2 * k]], description=f"{role} subject"),
            w.Dropdown(options=p_names, value=p_names[initial[2 * k + 1]], description=f"{role} pose"),
        ]
    chosen = w.SelectMultiple(options=list(by_name), value=tuple(by_name), description="methods", rows=len(by_name))
    image = w.Image(format="png")

    def solve(a, b, c):  # the answer's part where the analogy determines it: c when a == b, b when a == c
        return c if a == b else b if a == c else None

    def update(_=None):
        s = [boxes[2 * k].value for k in range(3)]
        p = [boxes[2 * k + 1].value for k in range(3)]
        V = generate_shapes(collection, np.stack([subjects[x] for x in s]), np.stack([poses[x] for x in p]))
        sx, px = solve(*s), solve(*p)
        truth = (
            None if sx is None or px is None else generate_shapes(collection, subjects[sx][None], poses[px][None])[0]
        )
        names, meshes, scalars = _with_errors({m: by_name[m].analogy(*V) for m in chosen.value}, truth)
        known = [("A", V[0]), ("B", V[1]), ("C", V[2])] + ([("true X", truth)] if truth is not None else [])
        box.titles = [n for n, _ in known] + names
        mm = [None if e is None else 1000 * e for e in scalars]
        image.value = render_png(
            [v for _, v in known] + meshes,
            collection.faces,
            box.titles,
            [None] * len(known) + mm,
            camera=camera,
            scalar_bar="distance to true X (mm)",
        )

    box = w.VBox([w.HBox(boxes[0:2]), w.HBox(boxes[2:4]), w.HBox(boxes[4:6]), chosen, image])
    box.image, box.controls = image, boxes
    for control in (*boxes, chosen):
        control.observe(update, names="value")
    update()
    return box
