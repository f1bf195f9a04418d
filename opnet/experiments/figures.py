"""The reproduction's figures (PNG, under ``OUT/figures``): training curves and reconstructions coloured by error,
the ablation's heat map, the applications' interpolation strips and analogy grids, refinement curves and steps, and
shapes given on other triangulations, and the rows beside Table 1 for generalisation.

matplotlib and pyvista (the ``viz`` extra) are imported when a figure is drawn, not with this module.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._extras import require
from ..evaluate import Method, evenly_spaced, operatornet_method, test_set_indices
from .paper import PAPER_ABLATION_DEPTHS
from .report import (
    MAPPED_GROUPS,
    PAPER_TABLE1_ROWS,
    ablation_columns,
    ablation_table,
    matches,
    row_key,
    upgrade_rows,
)

__all__ = [
    "table1_figures",
    "ablation_figure",
    "application_figures",
    "refinement_figures",
    "refinement_curves",
    "snapshot_steps",
    "most_deformed",
    "discretisation_figure",
    "generalisation_figure",
]


def table1_figures(out: Path, coll, ours, nn, histories: dict) -> None:
    """``training_curves.png`` (``histories``: name → a history, or a list of them, one per seed:
    :func:`opnet.plotting.plot_history`), and ``reconstructions_<split>.png``: three shapes of
    ``test`` and ``test_subjects`` reconstructed by ``ours`` and ``nn`` (:class:`opnet.evaluate.Method`), coloured by
    error. Written under ``out/figures``.
    """
    plt = require("matplotlib.pyplot", "opnet.reproduce's figures")

    from ..plotting import headless, plot_history, plot_reconstructions, side_view

    fig_dir = out / "figures"
    fig_dir.mkdir(exist_ok=True)
    fig = plot_history(histories)
    fig.savefig(fig_dir / "training_curves.png", dpi=120)
    plt.close(fig)
    headless()
    for split in ("test", "test_subjects"):
        idx = test_set_indices(coll, split)
        if len(idx) == 0:
            continue
        pick = evenly_spaced(idx, 3)
        plotter = plot_reconstructions(
            coll.vertices[pick],
            {ours.name: ours.reconstruct(pick), "NN": nn.reconstruct(pick)},
            coll.faces,
            titles=[str(coll.subcollection[i]) for i in pick],
            camera=side_view(coll),
        )
        plotter.screenshot(str(fig_dir / f"reconstructions_{split}.png"))
        plotter.close()


def ablation_figure(rows):
    """The ablation's heat map (:func:`opnet.plotting.plot_ablation` of :func:`ablation_table`, every set the rows
    hold: :func:`ablation_columns`), each cell with the half-width of its 95 % interval where its row has one: a
    matplotlib figure.
    """
    from ..plotting import plot_ablation

    return plot_ablation(
        ablation_table(rows),
        [f"Conv. {'×'.join(str(8 * 2**i) for i in range(d))}" for d in PAPER_ABLATION_DEPTHS],
        ablation_columns(rows),
        half_widths=ablation_table(rows, "half_width"),
    )


def application_figures(out: Path, coll, methods, quads, paths) -> None:
    """``interpolation_<kind>.png`` (each method on the path of ``paths`` that moves most) and ``analogy_<kind>.png``
    (each method on the first three questions of ``quads``), written in ``out``; ``methods``:
    :class:`opnet.apps.ShapeAlgebra` objects.
    """
    from ..metrics import d_R
    from ..plotting import headless, plot_analogies, plot_interpolations, side_view

    headless()
    out.mkdir(parents=True, exist_ok=True)
    for P in paths:
        i = int(np.argmax(d_R(P.truth[:, 0], P.truth[:, -1])))  # the path that moves most
        plotter = plot_interpolations(
            {m.name: m.interpolate(P.truth[i, 0], P.truth[i, -1], P.t) for m in methods},
            coll.faces,
            P.t,
            truth=P.truth[i],
            camera=side_view(coll),
        )
        plotter.screenshot(str(out / f"interpolation_{P.kind}.png"))
        plotter.close()
    for Q in quads:
        q = min(3, len(Q))
        plotter = plot_analogies(
            Q.A[:q],
            Q.B[:q],
            Q.C[:q],
            {m.name: m.analogy(Q.A[:q], Q.B[:q], Q.C[:q]) for m in methods},
            coll.faces,
            truth=Q.X[:q],
            camera=side_view(coll),
        )
        plotter.screenshot(str(out / f"analogy_{Q.kind}.png"))
        plotter.close()


def refinement_curves(
    coll, idx, inits: dict, steps: int, snapshot_steps=(), *, device="cpu", **options
) -> tuple[dict, dict]:
    """Run :func:`opnet.reconstruct` (with ``options``: ``channels``, default all of the collection's, ``optimizer``,
    ``smoothness``...) on shapes ``idx`` from each start in ``inits`` (name → ``"base"`` or vertices
    ``(len(idx), n, 3)``), recording after every step the mean relative operator mismatch and the mean ``d_R``.
    Returns ``curves`` (name → ``step``, ``mismatch``, ``d_R`` lists, for
    :func:`opnet.plotting.plot_refinement_curves`) and ``snapshots`` (name → step → vertices of the first shape).
    """
    from ..geometric import reconstruct
    from ..metrics import d_R

    options = dict(options, channels=coll.inner_products(options.get("channels")))
    gt = coll.vertices[idx].astype(np.float64)
    curves, snapshots = {}, {}
    for name, init in inits.items():
        c, snap = dict(step=[], mismatch=[], d_R=[]), {}

        def record(step, X, mismatch, c=c, snap=snap):
            c["step"].append(step)
            c["mismatch"].append(float(mismatch.mean()))
            c["d_R"].append(float(d_R(gt, X.cpu().numpy()).mean()))
            if step in snapshot_steps:
                snap[step] = X[0].cpu().numpy()

        reconstruct(
            coll.operators_for(options["channels"])[idx],
            coll.base_basis,
            init=init,
            steps=steps,
            callback=record,
            progress=False,
            batch_size=len(idx),
            device=device,
            **options,
        )  # one batch: one curve
        curves[name], snapshots[name] = c, snap
    return curves, snapshots


def snapshot_steps(steps: int) -> list[int]:
    """The steps shown in refinement figures: 0, 10, 100, ... up to ``steps``, and ``steps`` itself."""
    return sorted({s for s in (0, 10, 100, 1000) if s <= steps} | {steps})


def refinement_figures(out: Path, coll, net_method, steps: int, *, device="cpu", **options) -> None:
    """``refinement_curves.png`` (mismatch and d_R over ``steps`` steps of :func:`refinement_curves` with
    ``options``, from the base and from ``net_method``'s output, on up to 8 test shapes) and ``refinement_steps.png``
    (one shape after 0, 10, 100... steps, coloured by error), under ``out/figures``.
    """
    plt = require("matplotlib.pyplot", "opnet.reproduce's figures")

    from ..plotting import headless, plot_reconstructions, plot_refinement_curves, side_view

    idx = test_set_indices(coll, "test")
    idx = evenly_spaced(idx, 8)
    shown = snapshot_steps(steps)
    curves, snaps = refinement_curves(
        coll,
        idx,
        {"from the base (geometric)": "base", f"from {net_method.name}": net_method.reconstruct(idx)},
        steps,
        shown,
        device=device,
        **options,
    )
    fig = plot_refinement_curves(curves)
    fig.savefig(out / "figures" / "refinement_curves.png", dpi=120)
    plt.close(fig)
    headless()
    name = f"from {net_method.name}"
    plotter = plot_reconstructions(
        coll.vertices[idx[:1]],
        {f"step {s}": snaps[name][s][None] for s in shown},
        coll.faces,
        titles=["refined"],
        camera=side_view(coll),
    )
    plotter.screenshot(str(out / "figures" / "refinement_steps.png"))
    plotter.close()


def most_deformed(distances, motions, shapes: int) -> np.ndarray:
    """Indices (int, sorted, ``(min(shapes, N),)``) of ``shapes`` shapes far from the base and in different motions
    where there are enough: the farthest shape (largest ``distances``, (N,), finite) of each motion (``motions``, (N,)
    hashable labels), the motions in the order of those shapes' distances, then the farthest of the shapes left; of
    equal distances, the lower index first. A motion's frames look alike, so a figure of the ``shapes`` farthest
    shapes alone can show one motion three times.
    """
    distances = np.asarray(distances, dtype=float)
    if distances.ndim != 1 or len(motions) != len(distances):
        raise ValueError(f"distances (N,) and motions (N,) must match: got {distances.shape} and {len(motions)}.")
    if not np.isfinite(distances).all():
        raise ValueError("distances must be finite: a NaN or an infinity would rank first.")
    if not isinstance(shapes, (int, np.integer)) or isinstance(shapes, bool) or shapes < 1:
        raise ValueError(f"shapes must be a positive integer, got {shapes!r}.")
    order = np.argsort(-distances, kind="stable")  # farthest first; ties: the lower index first
    firsts = {}  # motion -> its farthest shape, in the order of their distances
    for i in order:
        firsts.setdefault(motions[i], i)
    chosen = list(firsts.values())[:shapes]
    taken = set(chosen)
    chosen += [i for i in order if i not in taken][: shapes - len(chosen)]
    return np.sort(np.array(chosen, dtype=int))


def discretisation_figure(mapped, nets: dict, shapes: int | None = None, *, labels: dict | None = None):
    """``shapes`` shapes (default three, or all of a smaller ``mapped``) of ``mapped``
    (:func:`opnet.data.mapped_collection` with computed maps) far from the base (the most deformed shape of each of
    the most deformed motions: ``most_deformed`` in this module), on
    their own mesh through their maps onto the base, and each reconstruction coloured by its error: a pyvista plotter
    (:func:`opnet.plotting.plot_mapped_reconstructions`; the maps are computed again, as they were for its operators:
    seconds each). ``nets``: name → network, or → an :class:`opnet.evaluate.Method` of the same shapes in the same
    order (a geometric reconstruction such as FuncChar's, whose collection carries other channels). ``labels``:
    name → ``mapped`` with the vertices and faces a network of ``nets`` decodes to when they are another mesh's (a
    network trained with finer labels, :func:`opnet.data.labels_collection`), the shapes it is measured against.
    """
    from ..data import Collection
    from ..data.generators import generate_shapes
    from ..data.humans import human_faces
    from ..matching import compute_map
    from ..mesh import Mesh
    from ..metrics import d_R
    from ..plotting import headless, plot_mapped_reconstructions
    from ..spectral import eigenbasis

    if not isinstance(mapped, Collection) or mapped.meta.get("maps") != "computed":
        raise ValueError("mapped must be a collection from opnet.data.mapped_collection(..., maps='computed').")
    shapes = min(3, len(mapped)) if shapes is None else shapes
    if not isinstance(shapes, (int, np.integer)) or isinstance(shapes, bool) or not 1 <= shapes <= len(mapped):
        raise ValueError(f"shapes must be an integer from 1 to len(mapped) = {len(mapped)}, got {shapes!r}.")
    if not nets:
        raise ValueError("nets is empty: give at least one name → network (or → opnet.evaluate.Method).")
    headless()
    base = np.broadcast_to(mapped.base_basis.mesh.vertices, mapped.vertices.shape)
    far = most_deformed(d_R(mapped.vertices, base), np.asarray(mapped.params["motion"]), shapes)
    res, k = mapped.meta["map_resolution"], mapped.meta["map_k"]
    fine = generate_shapes(mapped, mapped.params["phenotypes"][far], mapped.params["controls"][far], resolution=res)
    spectrum = eigenbasis(mapped.base_basis.mesh, k)
    maps = [compute_map(mapped.base_basis, Mesh(v, human_faces(res)), k=k, base_spectrum=spectrum) for v in fine]
    labels = labels or {}
    on = {name: labels.get(name, mapped) for name in nets}
    methods = {n: m if isinstance(m, Method) else operatornet_method(m, on[n], n) for n, m in nets.items()}
    recon = {name: method.reconstruct(far) for name, method in methods.items()}
    other = {name: (c.vertices[far], c.faces) for name, c in labels.items()}
    return plot_mapped_reconstructions(maps, recon, mapped.vertices[far], labels=other)


def generalisation_figure(rows: list[dict]):
    """The rows beside Table 1 for generalisation as a matplotlib figure, mean d_R (×10⁻⁴ m², that is cm²; log scale):
    a panel for each kind of rows ``rows`` holds.

    Unseen bodies: each OperatorNet on the three operators (Table 1's and those beside it, not the "Comp" networks of
    :data:`~opnet.experiments.report.MAPPED_GROUPS`), then its refinement where rows hold one, its ``test``
    (held-out sequences of seen bodies) and ``test_subjects`` (unseen bodies) errors side by side. Other
    triangulations: each network of the ``"discretisation"`` rows on the same test shapes given by their exact 1k
    operators and on the 2k and 5k meshes (true and computed maps), with the targets 1.5× and 3× the paper's
    network's 1k error drawn as lines. Rows are read by their structured fields (``table``, ``architecture``,
    ``channels``, ``group``, ``run`` and a row over seeds' ``runs``, ``refined``, ``bodies``, ``poses``, ``ensemble``,
    ``resolution``, ``maps``; ``d_R_low`` and ``d_R_high``, the 95 % interval drawn as an error bar where a row has
    one; an older file's rows are upgraded first, :func:`~opnet.experiments.report.upgrade_rows`); the method names
    only label them.
    """
    from ..inner_products import KINDS

    plt = require("matplotlib.pyplot", "generalisation_figure")
    rows = upgrade_rows(rows)
    table1 = [r for r in rows if r.get("table") == "table1" and r["split"] in ("test", "test_subjects")]
    runs = {  # the networks on the three operators, not the Comp ones; a row over seeds by its run and each seed's
        # (the refinement of such a network refines its first seed's run)
        run
        for r in table1
        if matches(r, architecture="operatornet", channels=KINDS, refined=None) and r.get("group") not in MAPPED_GROUPS
        for run in (r["run"], *(r.get("runs") or ()))
    }
    bodies = sorted((r for r in table1 if r.get("run") in runs), key=lambda r: bool(r.get("refined")))
    disc = [r for r in rows if r.get("table") == "discretisation"]
    paper = PAPER_TABLE1_ROWS["OperatorNet (Int+Ext)"]  # the targets: within 1.5x (2k) and 3x (5k) of its 1k error
    reference = [r for r in disc if (r["resolution"], r["maps"]) == ("1k", "exact") and matches(r, **paper)]
    panels = [(_bodies_panel, bodies, max(1.0, 0.2 * len({row_key(r) for r in bodies})))] if bodies else []
    panels += [(_triangulations_panel, (disc, reference), 1.0)] if disc else []  # (draw, its rows, its width)
    if not panels:
        raise ValueError("rows hold neither Table 1's OperatorNet rows nor 'discretisation' rows: nothing to draw.")
    widths = [w for _, _, w in panels]
    fig, axes = plt.subplots(1, len(panels), figsize=(6 * sum(widths), 5), gridspec_kw=dict(width_ratios=widths))
    for ax, (draw, part, _) in zip(np.atleast_1d(axes), panels, strict=True):
        draw(ax, part)
    fig.tight_layout()
    return fig


def _bodies_panel(ax, bodies: list) -> None:
    """:func:`generalisation_figure`'s unseen-bodies bars on ``ax``: a pair per method (:func:`row_key`)."""
    keys = list(dict.fromkeys(row_key(r) for r in bodies))
    for j, split in enumerate(("test", "test_subjects")):
        value = {row_key(r): r for r in bodies if r["split"] == split}
        x = np.arange(len(keys)) + (j - 0.5) * 0.38
        heights = [1e4 * value[k]["d_R"] if k in value else np.nan for k in keys]
        label = f"{split} ({'unseen' if j else 'seen'} bodies)"
        bars = ax.bar(x, heights, 0.38, color=("tab:blue", "tab:red")[j], label=label, yerr=_error_bars(value, keys))
        ax.bar_label(bars, fmt="%.3g", fontsize=7, padding=1)
    shapes = {(row_key(r), r["split"]): r["n_shapes"] for r in bodies}
    first = {row_key(r): r for r in reversed(bodies)}  # each method's fields

    def tick(k):
        r = first[k]
        name = {"paper": "paper's network", "ours": "our variant"}.get(r.get("variant"), f"{r.get('variant')} variant")
        name += "".join(f"\n{key}={r[key]}" for key in ("bodies", "poses") if r.get(key))
        name += f"\nensemble of {r['ensemble']}" if r.get("ensemble") else ""
        name += "\n+ refinement" if r.get("refined") else ""
        return name + f"\nn = {shapes.get((k, 'test'), 0)} / {shapes.get((k, 'test_subjects'), 0)}"

    ax.set_xticks(np.arange(len(keys)), [tick(k) for k in keys], fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel("mean d_R (×10⁻⁴ m² = cm²)")
    ax.set_title("Unseen bodies: OperatorNet (Int+Ext) beside Table 1 (n: test / test_subjects shapes)", fontsize=10)
    ax.legend(fontsize=8)


def _error_bars(value: dict, keys: list):
    """The ``yerr`` of bars of ``value[k]["d_R"]`` (×10⁻⁴): each row's 95 % interval below and above its mean, where
    rows have one (over seeds and shapes, :func:`opnet.experiments.stats.summarize_seeds`); ``None`` when none has.
    An interval that reaches 0 or below (a few seeds, a wide spread) is drawn down to a hundredth of the mean: the
    log axis has no 0.
    """
    lows = [value[k].get("d_R_low") if k in value else None for k in keys]
    if all(v is None for v in lows):
        return None
    lows = [None if lo is None else max(lo, 0.01 * value[k]["d_R"]) for k, lo in zip(keys, lows)]
    below = [1e4 * (value[k]["d_R"] - lo) if lo is not None else 0.0 for k, lo in zip(keys, lows)]
    above = [1e4 * (value[k]["d_R_high"] - value[k]["d_R"]) if lo is not None else 0.0 for k, lo in zip(keys, lows)]
    return np.array([below, above])


def _triangulations_panel(ax, part: tuple) -> None:
    """:func:`generalisation_figure`'s other-triangulations lines on ``ax`` (with error bars where a row has an
    interval): ``part`` is the discretisation rows and the reference rows of the targets' lines.
    """
    disc, reference = part
    encodings = list(dict.fromkeys((r["resolution"], r["maps"]) for r in disc))
    keys = list(dict.fromkeys(row_key(r) for r in disc))
    for i, k in enumerate(keys):
        rows = [r for r in disc if row_key(r) == k]
        value = {(r["resolution"], r["maps"]): r for r in rows}
        y = [1e4 * value[e]["d_R"] if e in value else np.nan for e in encodings]
        yerr = _error_bars(value, encodings)  # a network over seeds: its 95 % interval at each encoding
        x = np.arange(len(encodings)) + 0.05 * (i - (len(keys) - 1) / 2)  # side by side, so that the bars show
        ax.errorbar(x, y, yerr=yerr, fmt="o-", lw=0.8, capsize=2, label=rows[0]["method"])
    for r in reference:
        for factor, style in ((1.5, ":"), (3.0, "--")):
            ax.axhline(factor * 1e4 * r["d_R"], color="grey", ls=style, lw=1, label=f"{factor:g}× its 1k error")
    ax.set_xticks(range(len(encodings)), [f"{res}\n{maps}" for res, maps in encodings])
    ax.set_yscale("log")
    ax.set_ylabel("mean d_R (×10⁻⁴ m²)")
    ax.set_title(
        f"Other triangulations: {disc[0]['n_shapes']} test shapes per mesh (cf. the paper's Fig. 7)", fontsize=10
    )
    ax.legend(fontsize=7)
