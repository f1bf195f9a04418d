"""The pipeline behind ``python -m opnet reproduce``: data → Table 1 and the ablation → results.json/md, figures.

:func:`reproduce` builds (or reuses) the human collection of a preset, trains the networks it needs, each
in its own run directory under ``OUT/runs/`` (a second call skips finished runs, an interrupted one
continues from its last epoch), evaluates them beside the nearest-neighbour and base-shape baselines,
and writes

- ``OUT/results.json``: a list of rows ``{"table", "method", "channels", "depth", "split", "d_R", "d_V",
  "d_E"`` (means; ``*_median`` too), ``"n_shapes", "epochs", "train_seconds", "preset", "device"}``
  with ``d_R`` in m² (the paper reports it ×10⁻⁴);
- ``OUT/results.md``: Table 1 and the ablation laid out like the paper's, with its numbers beside ours;
- ``OUT/figures/``: training curves, the ablation heat map, reconstructions coloured by per-vertex error, and the
  applications' interpolation strips and analogy grids.

With ``maps=True`` (default) it also computes maps from the 2k-vertex version of every shape onto the base
(:func:`opnet.data.mapped_collection`), trains Table 1's "Comp" rows on the operators through them (:data:`COMP`),
and reconstructs test shapes given on other triangulations (:func:`discretisation_rows`: rows with ``"table"``
``"discretisation"``, and ``OUT/figures/discretisation.png``).

With ``applications=True`` (default) it also trains the PointNet autoencoder (a Table 1 row) and runs the
ground-truth analogy and interpolation benchmarks of :mod:`opnet.apps` (rows with ``"table"`` ``"analogy"`` and
``"interpolation"``). Table 1, the applications and ``results.*`` are written before the ablation.
"""

from __future__ import annotations

import json
import os
import platform
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ._checks import check_int
from ._extras import require
from ._files import atomic_write
from .evaluate import (
    TEST_SETS,
    _select,
    base_shape_method,
    channel_label,
    evaluate,
    evenly_spaced,
    geometric_method,
    nearest_neighbour_method,
    operatornet_method,
    pointnet_method,
    refined_method,
    test_set_indices,
)
from .shape_difference import KINDS
from .train import CHANNEL_SETS

__all__ = [
    "reproduce",
    "run_path",
    "table1_networks",
    "comp_networks",
    "discretisation_rows",
    "discretisation_indices",
    "discretisation_figure",
    "application_methods",
    "applications_rows",
    "applications_markdown",
    "discretisation_markdown",
    "ablation_table",
    "results_markdown",
    "refinement_curves",
    "snapshot_steps",
    "Budget",
    "BUDGETS",
    "TABLE1",
    "OURS",
    "COMP",
    "COMP_RESOLUTION",
    "DISCRETISATIONS",
    "DISCRETISATION_NETWORKS",
    "POINTNET",
    "REFINE",
    "REFINE_SETS",
    "ABLATION_SETS",
    "ABLATION_DEPTHS",
    "PAPER_TABLE1",
    "PAPER_ABLATION",
]


@dataclass(frozen=True)
class Budget:
    """Training settings of a preset: Table 1's epochs, the ablation's (fewer), batch size, learning rate."""

    epochs: int
    ablation_epochs: int
    batch_size: int = 32
    lr: float = 1e-3
    hidden: int = 1024
    refine_steps: int = 300
    refine_shapes: int = 80
    pointnet_epochs: int = 60
    analogies: int = 100  # analogy questions per kind
    paths: int = 10  # interpolation paths per kind
    apps_refine_shapes: int = 24  # shapes per kind the applications refine (seconds each)
    discretisation_shapes: int = 80  # test shapes the different-discretisation rows map (seconds each)


#: The training settings (:class:`Budget`) of each preset.
BUDGETS = {
    "quick": Budget(
        epochs=80,
        ablation_epochs=6,
        batch_size=16,
        refine_steps=30,
        refine_shapes=12,
        pointnet_epochs=40,
        analogies=24,
        paths=4,
        apps_refine_shapes=6,
        discretisation_shapes=12,
    ),
    "default": Budget(epochs=60, ablation_epochs=12),
    "paper": Budget(epochs=100, ablation_epochs=25),
}

#: Table 1's OperatorNet rows: name → input channels (depth 1, the paper's model).
TABLE1 = {
    "OperatorNet (Int+Ext)": KINDS,
    "OperatorNet (Int)": ("area", "conformal"),
    "OperatorNet (Ext)": ("extrinsic",),
}
#: The ablation's columns (Appendix B, in the paper's order) and rows.
ABLATION_SETS = CHANNEL_SETS
#: The ablation's encoder depths (its rows).
ABLATION_DEPTHS = (1, 2, 3, 4)

#: This project's variant (:data:`opnet.model.VARIANTS` ``["ours"]``), trained like Table 1's networks.
OURS = {"OperatorNet ours (Int+Ext)": KINDS}
#: The operator-matching rows (:func:`opnet.reconstruct`): its settings, chosen on ``val`` (README), and the
#: test sets they are evaluated on (at most ``Budget.refine_shapes`` shapes of each).
REFINE = dict(channels=("area", "extrinsic"), optimizer="lbfgs", smoothness=1.0)
#: The test sets on which the operator-matching rows are evaluated.
REFINE_SETS = ("test", "test_subjects")

#: Table 1's "Comp" rows: OperatorNet trained and tested on operators through maps computed from each shape's
#: :data:`COMP_RESOLUTION` mesh (:func:`opnet.matching.compute_map`), not the known correspondence.
COMP = {"OperatorNet (Comp)(Int+Ext)": KINDS, "OperatorNet (Comp)(Ext)": ("extrinsic",)}
#: The mesh (:data:`opnet.data.humans.RESOLUTIONS`) whose computed maps the "Comp" rows use.
COMP_RESOLUTION = "2k"
#: The different-discretisation rows: test shapes on these meshes, mapped onto the 1k base by these maps.
DISCRETISATIONS = (("2k", "true"), ("2k", "computed"), ("5k", "true"), ("5k", "computed"))
#: The networks that decode them (Table 1's and :data:`COMP`'s names).
DISCRETISATION_NETWORKS = ("OperatorNet (Int+Ext)", "OperatorNet (Ext)", *COMP)

#: Table 1's name of the PointNet autoencoder (:class:`opnet.model.PointNetAutoencoder`), trained with ``applications``.
POINTNET = "PointNet AE"

#: The paper's Table 1 on DFAUST (d_R ×10⁻⁴, d_V, d_E), for reference beside ours.
PAPER_TABLE1 = {
    "OperatorNet (Int+Ext)": (1.11, 0.014, 0.045),
    "OperatorNet (Int)": (2.41, 0.013, 0.046),
    "OperatorNet (Ext)": (1.25, 0.017, 0.046),
    "Nearest neighbour (Int+Ext)": (25.5, 0.005, 0.043),
    "OperatorNet (Comp)(Ext)": (3.86, 0.021, 0.052),
    "OperatorNet (Comp)(Int+Ext)": (6.22, 0.022, 0.053),
}
#: The paper's ablation (Appendix B, d_R ×10⁻⁴ on the DFAUST test set): depth → values in ABLATION_SETS order.
PAPER_ABLATION = {
    1: (8.61, 4.29, 3.78, 3.82, 3.41, 2.56, 2.46),
    2: (9.08, 4.54, 4.28, 4.65, 3.93, 3.10, 3.05),
    3: (9.90, 5.54, 4.91, 5.59, 4.88, 3.71, 3.55),
    4: (11.16, 6.39, 5.93, 6.89, 5.42, 4.35, 4.24),
}
_SPLIT_NAMES = {"eval_subset": "50-shape subset", "test": "test", "test_subjects": "unseen subjects"}


def _machine(device) -> str:
    import torch

    if device.type == "cuda":
        return f"{torch.cuda.get_device_name(device)} (CUDA), torch {torch.__version__}"
    return (
        f"CPU ({platform.machine()}, {os.cpu_count()} cores, {torch.get_num_threads()} torch threads), "
        f"torch {torch.__version__}"
    )


def reproduce(
    preset: str = "quick",
    out=None,
    *,
    device="auto",
    ablation: bool = True,
    figures: bool = True,
    refine: bool = True,
    applications: bool = True,
    maps: bool = True,
    budget: Budget | None = None,
    data_root=None,
    progress: bool | None = None,
) -> list[dict]:
    """Reproduce the paper's Table 1 and ablation on the generated humans at ``preset``; returns the rows.

    Parameters
    ----------
    preset : ``"quick"`` (minutes on a laptop CPU), ``"default"`` or ``"paper"``.
    out : path, the output folder (default ``reproduce-<preset>``); reused to resume.
    device : ``"auto"`` (CUDA when available), ``"cpu"``, ``"cuda"``.
    ablation : also train and evaluate the depth × channels grid (Appendix B).
    figures : also write the figures (PNG) under ``out/figures``.
    refine : also evaluate the operator-matching rows: the geometric baseline and OperatorNet + refinement
        (:func:`opnet.reconstruct` with :data:`REFINE`, ``budget.refine_steps`` steps, on at most
        ``budget.refine_shapes`` shapes of each of :data:`REFINE_SETS`, evenly spaced: they take seconds per shape).
    maps : also the computed-map rows: Table 1's "Comp" networks (:func:`comp_networks`; computing the maps of the
        whole collection takes about 0.6 s per shape and core, done once and cached beside the collection) and the
        different-discretisation rows (:func:`discretisation_rows`, ``budget.discretisation_shapes`` test shapes).
    applications : also train the PointNet autoencoder (Table 1's "PointNet AE" row) and run the analogy and
        interpolation benchmarks (:func:`applications_rows`; ``budget.analogies`` questions and ``budget.paths``
        paths per kind).
    budget : training settings; default ``BUDGETS[preset]``.
    data_root : where collections are cached (default ``opnet.data.default_root()``).
    progress : ``None`` (default): one progress bar over the networks; ``True``: also a bar per network over
        its epochs (the command line's choice); ``False``: none.
    """
    from .data import load_collection
    from .train import resolve_device

    if preset not in BUDGETS:
        raise ValueError(f"unknown preset {preset!r}; use one of {list(BUDGETS)}.")
    budget = budget or BUDGETS[preset]
    out = Path(out if out is not None else f"reproduce-{preset}")
    if out.exists() and not out.is_dir():
        raise ValueError(f"out={out} is a file; give a folder.")
    (out / "runs").mkdir(parents=True, exist_ok=True)
    device = resolve_device(device)
    t_start = time.perf_counter()
    coll = load_collection("humans", preset, root=data_root, progress=progress)
    info = dict(preset=preset)

    from tqdm.auto import tqdm

    runs = tqdm(
        total=len(TABLE1)
        + len(OURS)
        + bool(applications)
        + (len(COMP) if maps else 0)
        + (len(ABLATION_DEPTHS) * len(ABLATION_SETS) if ablation else 0),
        desc="reproduce",
        unit="network",
        disable=progress is False,
    )

    nets, histories, devices = table1_networks(
        coll, out, budget, pointnet=applications, device=device, progress=progress, bar=runs
    )
    methods = [operatornet_method(nets[name], coll, name) for name in (*TABLE1, *OURS)]
    methods += [pointnet_method(nets[POINTNET], coll, POINTNET)] if applications else []
    for m in methods:
        m.info = dict(table="table1", **devices[m.name])
    if maps:
        comp, comp_nets, comp_histories, comp_devices = comp_networks(
            coll, out, budget, device=device, bar=runs, progress=progress, data_root=data_root
        )
        nets.update(comp_nets)
        histories.update(comp_histories)
        comp_methods = [operatornet_method(net, comp, name) for name, net in comp_nets.items()]
        for m in comp_methods:
            m.info = dict(table="table1", **comp_devices[m.name])
    baselines = [nearest_neighbour_method(coll, KINDS), base_shape_method(coll)]
    matching = []
    if refine:
        options = dict(REFINE, steps=budget.refine_steps, max_shapes=budget.refine_shapes, device=device)
        matching = [geometric_method(coll, **options)]
        matching += [refined_method(m, coll, **options) for m in methods if m.channels == KINDS]
    for m in baselines + matching:
        m.info = dict(table="table1", epochs=None, train_seconds=None, device=str(device))
    rows = evaluate(coll, methods + baselines, TEST_SETS, extra=info)
    rows += evaluate(comp, comp_methods, TEST_SETS, extra=info) if maps else []
    rows += evaluate(coll, matching, REFINE_SETS, extra=info)
    if maps:
        rows += discretisation_rows(
            coll,
            {name: nets[name] for name in DISCRETISATION_NETWORKS},
            budget,
            comp=comp,
            data_root=data_root,
            progress=progress,
            out=out / "figures" if figures else None,
            extra=info,
        )
    context = dict(
        preset=preset,
        budget=asdict(budget),
        machine=_machine(device),
        collection=repr(coll),
        splits={s: int(np.sum(coll.split == s)) for s in ("train", "val", "test", "test_subjects")},
        eval_subset=int(len(coll.eval_subset)),
    )
    _write(out, rows, context, time.perf_counter() - t_start)
    if figures:
        _figures(
            out,
            coll,
            methods[0],
            baselines[0],
            {k.split(" ", 1)[1] if k.startswith("OperatorNet") else k: h for k, h in histories.items()},
        )
        if refine:
            _refinement_figures(out, coll, methods[0], budget, device)
    if applications:
        algebras = application_methods(coll, nets, budget, refine=refine, device=device)
        rows += applications_rows(coll, algebras, budget, out=out / "figures" if figures else None, progress=progress)
        _write(out, rows, context, time.perf_counter() - t_start)

    if ablation:
        for depth in ABLATION_DEPTHS:
            for label, channels in ABLATION_SETS.items():
                net, _, run_info = _train(
                    coll,
                    out,
                    budget,
                    channels,
                    depth,
                    budget.ablation_epochs,
                    "ablation",
                    device=device,
                    progress=progress,
                    bar=runs,
                )
                m = operatornet_method(net, coll, f"OperatorNet ({label}) depth {depth}")
                m.info = dict(table="ablation", **run_info)
                rows += evaluate(coll, [m], ("test",), extra=info)
        _write(out, rows, context, time.perf_counter() - t_start)
        if figures:
            plt = require("matplotlib.pyplot", "opnet.reproduce's figures")

            fig = _ablation_figure(rows)
            fig.savefig(out / "figures" / "ablation.png", dpi=120)
            plt.close(fig)
    runs.close()
    return rows


def _train(coll, out, budget: Budget, channels, depth, epochs, tag, variant="paper", *, device, progress, bar=None):
    """Train (or load, when finished) one network of the reproduction in its run directory (:func:`run_path`)."""
    from .train import fit

    run_dir = run_path(out, tag, channels, depth, variant)
    if bar is not None:
        bar.set_postfix_str(run_dir.name)
    options = (
        dict(architecture="pointnet")
        if variant == "pointnet"
        else dict(channels=channels, depth=depth, variant=variant)
    )
    net, history = fit(
        coll,
        epochs=epochs,
        batch_size=budget.batch_size,
        lr=budget.lr,
        hidden=budget.hidden,
        device=device,
        run_dir=run_dir,
        progress=progress is True,
        **options,
    )
    if bar is not None:
        bar.update(1)
    trained_on = json.loads((run_dir / "config.json").read_text())["device"]  # a reused run may come from elsewhere
    return (
        net,
        history,
        dict(epochs=len(history), train_seconds=round(sum(e["seconds"] for e in history), 1), device=trained_on),
    )


def table1_networks(
    coll, out, budget: Budget, *, pointnet: bool = True, device="cpu", progress=None, bar=None
) -> tuple[dict, dict, dict]:
    """Table 1's networks (:data:`TABLE1`, :data:`OURS` and, with ``pointnet``, :data:`POINTNET`), trained in
    ``out/runs/`` or loaded when already trained there: dicts name → network, name → history, name → run info
    (``epochs``, ``train_seconds``, ``device``). :func:`reproduce` and the notebooks share them this way.
    """
    nets, histories, info = {}, {}, {}
    todo = [(name, channels, "paper", budget.epochs) for name, channels in TABLE1.items()]
    todo += [(name, channels, "ours", budget.epochs) for name, channels in OURS.items()]
    todo += [(POINTNET, None, "pointnet", budget.pointnet_epochs)] if pointnet else []
    for name, channels, variant, epochs in todo:
        nets[name], histories[name], info[name] = _train(
            coll, out, budget, channels, 1, epochs, "table1", variant, device=device, progress=progress, bar=bar
        )
    return nets, histories, info


def comp_networks(coll, out, budget: Budget, *, device="cpu", progress=None, bar=None, data_root=None) -> tuple:
    """Table 1's "Comp" networks (:data:`COMP`), trained in ``out/runs/comp-*`` (or loaded when trained there) on
    ``comp = opnet.data.mapped_collection(coll, COMP_RESOLUTION)``: the same shapes, with operators through maps
    computed from their 2k-vertex meshes. Returns ``comp`` and, like :func:`table1_networks`, dicts name →
    network, name → history, name → run info.
    """
    from .data import mapped_collection

    comp = mapped_collection(coll, COMP_RESOLUTION, "computed", root=data_root, progress=progress)
    nets, histories, info = {}, {}, {}
    for name, channels in COMP.items():
        nets[name], histories[name], info[name] = _train(
            comp, out, budget, channels, 1, budget.epochs, "comp", device=device, progress=progress, bar=bar
        )
    return comp, nets, histories, info


def discretisation_rows(
    coll, nets: dict, budget: Budget, *, comp=None, data_root=None, progress=None, out=None, extra: dict | None = None
) -> list[dict]:
    """Reconstructions of test shapes given on other triangulations: rows with ``"table"`` ``"discretisation"``.

    At most ``budget.discretisation_shapes`` shapes of ``test`` (evenly spaced, :func:`discretisation_indices`) are
    generated on each mesh of :data:`DISCRETISATIONS` and mapped onto the base by the true or the computed map
    (:func:`opnet.data.mapped_collection`), and, as a reference, taken with their exact 1k operators (``resolution``
    ``"1k"``, ``maps`` ``"exact"``). Every network of ``nets`` (name → network) decodes every encoding; d_R, d_V,
    d_E against the generator's 1k shapes. Rows also hold ``resolution``, ``maps`` and ``map_error`` (metres, mean
    over the shapes; 0 for the true map). ``comp``: the :func:`comp_networks` collection, whose 2k computed maps
    are reused. With ``out``, writes ``discretisation.png`` there (:func:`discretisation_figure` of three 5k shapes).
    """
    from .data import mapped_collection
    from .data.mapped import MAP_K

    idx = discretisation_indices(coll, budget)
    encodings = {("1k", "exact"): coll.subset(idx)}
    for res, maps in DISCRETISATIONS:
        if comp is not None and _maps_of(comp, coll, res, maps, MAP_K):
            encodings[res, maps] = comp.subset(idx)
        else:
            encodings[res, maps] = mapped_collection(coll, res, maps, indices=idx, root=data_root, progress=progress)
    rows = []
    for (res, maps), c in encodings.items():
        error = float(np.mean(c.params["map_error"])) if "map_error" in c.params else 0.0
        methods = [operatornet_method(net, c, name) for name, net in nets.items()]
        for m in methods:
            m.info = dict(table="discretisation", resolution=res, maps=maps, map_error=error)
        rows += evaluate(c, methods, ("test",), extra=extra)
    if out is not None:
        shown = {name: nets[name] for name in ("OperatorNet (Int+Ext)", next(iter(COMP))) if name in nets}
        plotter = discretisation_figure(encodings["5k", "computed"], shown or nets)
        Path(out).mkdir(parents=True, exist_ok=True)
        plotter.screenshot(str(Path(out) / "discretisation.png"))
        plotter.close()
    return rows


def _maps_of(mapped, coll, resolution: str, maps: str, k: int) -> bool:
    """Whether ``mapped`` is ``mapped_collection(coll, resolution, maps, k=k)`` (all of ``coll``'s shapes)."""
    meta, params = mapped.meta, mapped.params
    same_maps = (meta.get("map_resolution"), meta.get("maps"), meta.get("map_k")) == (resolution, maps, k)
    return (
        same_maps
        and len(mapped) == len(coll)
        and all(np.array_equal(params.get(key), coll.params.get(key)) for key in ("phenotypes", "controls"))
    )


def discretisation_indices(coll, budget: Budget) -> np.ndarray:
    """The ``test`` shapes of :func:`discretisation_rows`: at most ``budget.discretisation_shapes``, evenly spaced."""
    check_int("budget.discretisation_shapes", budget.discretisation_shapes)
    return evenly_spaced(test_set_indices(coll, "test"), budget.discretisation_shapes)


def discretisation_figure(mapped, nets: dict, shapes: int = 3):
    """The ``shapes`` shapes of ``mapped`` (:func:`opnet.data.mapped_collection` with computed maps) that are farthest
    from the base (the most deformed), on their own mesh through their maps onto the base, and each network's
    reconstruction (name → network) coloured by its error: a pyvista plotter
    (:func:`opnet.plotting.plot_mapped_reconstructions`; the maps are computed again, as they were for its operators:
    seconds each).
    """
    from .data import Collection
    from .data.generators import generate_shapes
    from .data.humans import human_faces
    from .matching import compute_map
    from .mesh import Mesh
    from .metrics import d_R
    from .plotting import headless, plot_mapped_reconstructions
    from .spectral import eigenbasis

    if not isinstance(mapped, Collection) or mapped.meta.get("maps") != "computed":
        raise ValueError("mapped must be a collection from opnet.data.mapped_collection(..., maps='computed').")
    if not isinstance(shapes, (int, np.integer)) or isinstance(shapes, bool) or not 1 <= shapes <= len(mapped):
        raise ValueError(f"shapes must be an integer from 1 to len(mapped) = {len(mapped)}, got {shapes!r}.")
    if not nets:
        raise ValueError("nets is empty: give at least one name → network.")
    headless()
    base = np.broadcast_to(mapped.base_basis.mesh.vertices, mapped.vertices.shape)
    far = np.sort(np.argsort(d_R(mapped.vertices, base))[-shapes:])
    res, k = mapped.meta["map_resolution"], mapped.meta["map_k"]
    fine = generate_shapes(mapped, mapped.params["phenotypes"][far], mapped.params["controls"][far], resolution=res)
    spectrum = eigenbasis(mapped.base_basis.mesh, k)
    maps = [compute_map(mapped.base_basis, Mesh(v, human_faces(res)), k=k, base_spectrum=spectrum) for v in fine]
    recon = {name: operatornet_method(net, mapped, name).reconstruct(far) for name, net in nets.items()}
    return plot_mapped_reconstructions(maps, recon, mapped.vertices[far])


def run_path(out, table: str, channels, depth: int = 1, variant: str = "paper") -> Path:
    """The run directory :func:`reproduce` uses for one network: ``out/runs/<table>-<channels>-d<depth>``.

    ``table`` is ``"table1"``, ``"comp"`` or ``"ablation"``; ``channels`` a set of kinds (short name ``A+E+C``,
    ``Ext``...);
    ``variant="ours"`` (:func:`opnet.train.fit`) adds ``-ours``; ``variant="pointnet"`` names the PointNet
    autoencoder's run, ``out/runs/<table>-pointnet`` (``channels`` and ``depth`` are then ignored).
    """
    if out is None:
        raise TypeError("out must be the reproduction's folder (its runs/ hold the networks), not None.")
    if variant == "pointnet":
        return Path(out) / "runs" / f"{table}-pointnet"
    short = next(k for k, v in ABLATION_SETS.items() if set(v) == set(channels))
    return Path(out) / "runs" / f"{table}-{short}-d{depth}{'' if variant == 'paper' else '-' + variant}"


def application_methods(coll, nets: dict, budget: Budget, *, refine: bool = True, device="cpu") -> list:
    """The applications' methods (:class:`opnet.apps.ShapeAlgebra`): Table 1's OperatorNet (Int+Ext) with the
    multiplicative and the linear algebra, our variant, the first + refinement (:data:`REFINE`, at most
    ``budget.apps_refine_shapes`` shapes per kind), the PointNet AE and NN. ``nets``: Table 1's name → network.
    """
    from . import apps

    paper, ours = nets["OperatorNet (Int+Ext)"], nets[next(iter(OURS))]
    methods = [
        apps.operatornet_algebra(paper, coll),
        apps.operatornet_algebra(paper, coll, scheme="linear"),
        apps.operatornet_algebra(ours, coll, name="OperatorNet ours (mult.)"),
    ]
    if refine:
        methods.append(
            apps.operatornet_algebra(
                paper,
                coll,
                refine=dict(REFINE, steps=budget.refine_steps, device=device),
                max_shapes=budget.apps_refine_shapes,
            )
        )
    return methods + [apps.pointnet_algebra(nets[POINTNET], coll), apps.nearest_neighbour_algebra(coll)]


def applications_rows(coll, methods, budget: Budget, *, out=None, progress=None, seed: int = 0) -> list[dict]:
    """Run the ground-truth analogy (``budget.analogies`` questions per kind) and interpolation (``budget.paths``
    paths of 11 steps per kind) benchmarks of :mod:`opnet.apps`; rows get ``table`` ``"analogy"`` or
    ``"interpolation"``. With ``out``, also writes ``interpolation_<kind>.png`` and ``analogy_<kind>.png`` there.
    """
    from . import apps

    quads = [apps.analogy_quadruples(coll, kind, budget.analogies, seed=seed) for kind in apps.ANALOGY_KINDS]
    paths = [apps.interpolation_paths(coll, kind, budget.paths, seed=seed) for kind in apps.PATH_KINDS]
    rows = [dict(r, table="analogy") for r in apps.analogy_benchmark(coll, methods, quads, progress=progress)]
    rows += [
        dict(r, table="interpolation") for r in apps.interpolation_benchmark(coll, methods, paths, progress=progress)
    ]
    if out is not None:
        _application_figures(Path(out), coll, methods, quads, paths)
    return [dict(r, preset=coll.meta.get("preset")) for r in rows]


def _application_figures(out: Path, coll, methods, quads, paths) -> None:
    from .metrics import d_R
    from .plotting import headless, plot_analogies, plot_interpolations

    headless()
    out.mkdir(parents=True, exist_ok=True)
    for P in paths:
        i = int(np.argmax(d_R(P.truth[:, 0], P.truth[:, -1])))  # the path that moves most
        plotter = plot_interpolations(
            {m.name: m.interpolate(P.truth[i, 0], P.truth[i, -1], P.t) for m in methods},
            coll.faces,
            P.t,
            truth=P.truth[i],
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
        )
        plotter.screenshot(str(out / f"analogy_{Q.kind}.png"))
        plotter.close()


def ablation_table(rows) -> np.ndarray:
    """The ablation's d_R ×10⁻⁴ on ``test`` as a ``(depths, sets)`` array (NaN where not trained yet)."""
    table = np.full((len(ABLATION_DEPTHS), len(ABLATION_SETS)), np.nan)
    for r in rows:
        if r.get("table") == "ablation":
            label = r["method"][len("OperatorNet (") :].split(")")[0]
            table[ABLATION_DEPTHS.index(r["depth"]), list(ABLATION_SETS).index(label)] = 1e4 * r["d_R"]
    return table


def _ablation_figure(rows):
    from .plotting import plot_ablation

    return plot_ablation(
        ablation_table(rows),
        [f"Conv. {'×'.join(str(8 * 2**i) for i in range(d))}" for d in ABLATION_DEPTHS],
        list(ABLATION_SETS),
    )


def _fmt(v, scale=1.0, digits=3) -> str:
    return "–" if v is None or not np.isfinite(v) else f"{scale * v:.{digits}g}"


def _write(out: Path, rows: list[dict], context: dict, seconds: float) -> None:
    atomic_write(out / "results.json", lambda f: f.write(json.dumps(rows, indent=1).encode()))
    md = results_markdown(rows, dict(context, wall_seconds=round(seconds, 1)))
    atomic_write(out / "results.md", lambda f: f.write(md.encode()))


def results_markdown(rows: list[dict], context: dict) -> str:
    """``results.md``: Table 1 (per test set, with the paper's numbers), the targets, and the ablation."""
    b = context["budget"]
    lines = [
        f"# OperatorNet reproduction · preset `{context['preset']}`",
        "",
        f"Machine: {context['machine']}. Wall time so far: {context['wall_seconds']:.0f} s "
        "(data, training, evaluation; finished runs are reused, so a resumed call counts only what it did).",
        "",
        f"Data: {context['collection']}; the 50-shape evaluation subset has {context['eval_subset']} shapes.",
        "",
        f"Training: Adam, lr {b['lr']}, batch {b['batch_size']}, {b['epochs']} epochs for Table 1's OperatorNets "
        f"({b.get('pointnet_epochs', b['epochs'])} for the PointNet AE) and {b['ablation_epochs']} for the ablation "
        "(fewer, to keep the 28-network grid affordable); model "
        "selection on `val`. The paper's numbers are on DFAUST, ours on `anny` humans: the scale (metres) is "
        "alike, the data are not the same.",
        "",
        "## Table 1: shape reconstruction",
        "",
        "d_R ×10⁻⁴ (m²), mean (median in brackets).",
        "",
    ]
    t1 = [r for r in rows if r.get("table") == "table1"]
    methods = list(dict.fromkeys(r["method"] for r in t1))
    splits = [s for s in TEST_SETS if any(r["split"] == s for r in t1)]
    head = (
        "| method | "
        + " | ".join(f"{_SPLIT_NAMES[s]}: d_R | d_V | d_E" for s in splits)
        + " | paper d_R | d_V | d_E | train s | s/shape |"
    )
    lines += [head, "|---" * (2 + 3 * len(splits) + 4) + "|"]
    subsampled = {}
    for m in methods:
        cells = []
        for s in splits:
            r = next((r for r in t1 if r["method"] == m and r["split"] == s), None)
            cells += (
                [f"{_fmt(r['d_R'], 1e4)} ({_fmt(r['d_R_median'], 1e4)})", _fmt(r["d_V"]), _fmt(r["d_E"])]
                if r
                else ["–"] * 3
            )
            full = next((q["n_shapes"] for q in t1 if q["split"] == s and q["method"] == methods[0]), None)
            if r and full is not None and r["n_shapes"] < full:
                subsampled.setdefault(m, []).append(f"{r['n_shapes']} of the {full} shapes of {_SPLIT_NAMES[s]}")
        paper = PAPER_TABLE1.get(m, (None, None, None))
        mine = [r for r in t1 if r["method"] == m]
        secs = mine[0]["train_seconds"]
        per_shape = np.mean([r["seconds_per_shape"] for r in mine if "seconds_per_shape" in r] or [np.nan])
        lines.append(
            f"| {m} | "
            + " | ".join(cells)
            + " | "
            + " | ".join("–" if p is None else f"{p:g}" for p in paper)
            + f" | {'–' if secs is None else f'{secs:.0f}'} | {_fmt(per_shape, digits=2)} |"
        )
    lines += [
        "",
        "s/shape: the method's wall time per reconstructed shape (decoding, search or optimisation; not training).",
    ]
    for m, where in subsampled.items():
        lines.append(
            f"{m}: evaluated on {', '.join(where)} (evenly spaced, to bound the optimisation's time; "
            "`Budget.refine_shapes`)."
        )
    lines += ["", "## Targets", ""] + _targets(t1)
    table = ablation_table(rows)
    if np.isfinite(table).any():
        cols = list(ABLATION_SETS)
        lines += [
            "",
            "## Ablation (Appendix B): d_R ×10⁻⁴ on `test`",
            "",
            f"Each network trained {b['ablation_epochs']} epochs (Table 1's have {b['epochs']}).",
            "",
            "| encoder | " + " | ".join(cols) + " |",
            "|---" * (len(cols) + 1) + "|",
        ]
        for i, d in enumerate(ABLATION_DEPTHS):
            best = np.nanargmin(table[i]) if np.isfinite(table[i]).any() else -1
            cells = [f"**{_fmt(v)}**" if j == best else _fmt(v) for j, v in enumerate(table[i])]
            lines.append(f"| Conv. {'×'.join(str(8 * 2**k) for k in range(d))} | " + " | ".join(cells) + " |")
        lines += [
            "",
            "The paper's (DFAUST):",
            "",
            "| encoder | " + " | ".join(cols) + " |",
            "|---" * (len(cols) + 1) + "|",
        ]
        for d, vals in PAPER_ABLATION.items():
            lines.append(
                f"| Conv. {'×'.join(str(8 * 2**k) for k in range(d))} | " + " | ".join(f"{v:g}" for v in vals) + " |"
            )
        done = table[:, -1]
        nn = next((r["d_R"] for r in t1 if r["method"] == "Nearest neighbour (Int+Ext)" and r["split"] == "test"), None)
        if nn is not None and np.nanmin(table) > 0.5e4 * nn:
            lines += [
                "",
                f"**Caveat:** with {b['ablation_epochs']} epochs at this preset the ablation networks are barely "
                f"trained (every cell is above half of NN's {_fmt(nn, 1e4)}), so the differences between cells are "
                "mostly noise: this table shows the pipeline, not the paper's trends. Use a larger preset.",
            ]
        if np.isfinite(table).all():
            best_col = np.mean(np.argmin(table, axis=1) == len(cols) - 1)
            lines += [
                "",
                f"All three operators give the best column in {best_col:.0%} of the depths (the paper: 100 %); "
                f"depth 1 is {'the best' if np.argmin(done) == 0 else 'not the best'} for A+E+C "
                f"({', '.join(_fmt(v) for v in done)} for depths 1–4).",
            ]
    lines += discretisation_markdown(rows)
    lines += applications_markdown(rows)
    return "\n".join(lines) + "\n"


def discretisation_markdown(rows: list[dict]) -> list[str]:
    """The different-discretisation section of ``results.md`` (lines): d_R per encoding and network, and the target."""
    disc = [r for r in rows if r.get("table") == "discretisation"]
    if not disc:
        return []
    nets = list(dict.fromkeys(r["method"] for r in disc))
    encodings = list(dict.fromkeys((r["resolution"], r["maps"]) for r in disc))
    get = {(r["resolution"], r["maps"], r["method"]): r for r in disc}
    lines = [
        "",
        "## Other triangulations: test shapes on 2k and 5k meshes",
        "",
        f"{disc[0]['n_shapes']} `test` shapes (evenly spaced) generated on each mesh, mapped onto the 1k base "
        "by the generator's true correspondence or by a computed map (`opnet.matching.compute_map`), encoded "
        "through the map and decoded by each network; d_R ×10⁻⁴ against the 1k shapes (median in brackets). "
        "Map error: mean distance between where the computed and the true map send a vertex. *1k exact*: the "
        "same shapes' own operators.",
        "",
        "| mesh | map | map error (cm) | " + " | ".join(nets) + " |",
        "|---" * (3 + len(nets)) + "|",
    ]
    for res, maps in encodings:
        first = get[res, maps, nets[0]]
        cells = [
            f"{_fmt(get[res, maps, n]['d_R'], 1e4)} ({_fmt(get[res, maps, n]['d_R_median'], 1e4)})"
            if (res, maps, n) in get
            else "–"
            for n in nets
        ]
        error = "–" if maps == "exact" else f"{100 * first['map_error']:.2f}"
        lines.append(f"| {res} | {maps} | {error} | " + " | ".join(cells) + " |")
    exact = get.get(("1k", "exact", "OperatorNet (Int+Ext)"))
    fine = [get[key] for key in get if key[:2] == ("5k", "computed")]
    if exact is not None and fine:
        lines += [
            "",
            f"**Target:** 5k → 1k through computed maps within 3× of OperatorNet (Int+Ext)'s error on the "
            f"exact 1k operators of the same shapes ({_fmt(exact['d_R'], 1e4)}), for each network:",
            "",
        ]
        lines += [
            f"- {r['method']}: {_fmt(r['d_R'], 1e4)}, {r['d_R'] / exact['d_R']:.1f}×: "
            f"{'met' if r['d_R'] <= 3 * exact['d_R'] else 'missed'}."
            for r in fine
        ]
    return lines


_KIND_NAMES = {
    "analogy": {"pose": "pose transfer (a,p):(a,q)::(b,p):(b,q)", "body": "body transfer (a,p):(b,p)::(a,q):(b,q)"},
    "interpolation": {"pose": "one subject, pose to pose", "body": "one pose, subject to subject"},
}


def applications_markdown(rows: list[dict]) -> list[str]:
    """The applications' section of ``results.md`` (lines): the analogy and interpolation tables and their targets."""
    ana = [r for r in rows if r.get("table") == "analogy"]
    itp = [r for r in rows if r.get("table") == "interpolation"]
    if not ana and not itp:
        return []
    lines = [
        "",
        "## Applications: analogy and interpolation against ground truth",
        "",
        "Subjects from `test_subjects`, poses from the `test` sequences; the true shapes are generated from the "
        "generator's parameters (`opnet.apps`). d_R ×10⁻⁴ (median in brackets). *direct*: the same method on "
        "X given X itself (its floor: the rest is the algebra's error).",
    ]
    for kind in dict.fromkeys(r["kind"] for r in ana):
        part = [r for r in ana if r["kind"] == kind]
        lines += [
            "",
            f"**Analogy, {_KIND_NAMES['analogy'].get(kind, kind)}** ({part[0]['n']} questions)",
            "",
            "| method | n | d_R | d_V | d_E | direct d_R |",
            "|---|---|---|---|---|---|",
        ]
        for r in part:
            before = f" (before: {_fmt(r['d_R_before'], 1e4)})" if "d_R_before" in r else ""
            lines.append(
                f"| {r['method']} | {r['n']} | {_fmt(r['d_R'], 1e4)} ({_fmt(r['d_R_median'], 1e4)}){before} | "
                f"{_fmt(r['d_V'])} | {_fmt(r['d_E'])} | {_fmt(r['d_R_direct'], 1e4)} |"
            )
    for kind in dict.fromkeys(r["kind"] for r in itp):
        part = [r for r in itp if r["kind"] == kind]
        lines += [
            "",
            f"**Interpolation, {_KIND_NAMES['interpolation'].get(kind, kind)}** ({part[0]['n_paths']} paths of "
            f"{part[0]['steps']} steps)",
            "",
            "| method | paths | endpoints d_R | in-between d_R | edge distortion | smoothness (worst) |",
            "|---|---|---|---|---|---|",
        ]
        for r in part:
            lines.append(
                f"| {r['method']} | {r['n_paths']} | {_fmt(r['endpoint_d_R'], 1e4)} | {_fmt(r['d_R_truth'], 1e4)} | "
                f"{_fmt(r['distortion'])} | {_fmt(r['smoothness'])} ({_fmt(r['smoothness_max'])}) |"
            )
    if itp:
        lines += [
            "",
            f"Edge distortion: the largest mean relative edge-length error against the nearer true endpoint; "
            f"smoothness: the largest step over the path length ({1 / (itp[0]['steps'] - 1):.2f} for even steps).",
        ]
    targets = []
    for kind in dict.fromkeys(r["kind"] for r in ana):
        get = {r["method"]: r["d_R"] for r in ana if r["kind"] == kind}
        ours = get.get("OperatorNet (mult.)")
        others = {m: get[m] for m in (POINTNET, "Nearest neighbour") if m in get}
        if ours is not None and others:
            met = all(v > ours for v in others.values())
            ratios = ", ".join(f"{m} / OperatorNet = {v / ours:.2f}" for m, v in others.items())
            targets.append(
                f"- analogy, {kind}: {ratios} (target: OperatorNet (mult.) beats both at `default`): "
                f"{'met' if met else 'missed'}."
            )
    return lines + (["", "**Targets**", ""] + targets if targets else [])


def _targets(t1: list[dict]) -> list[str]:
    def get(method, split, key="d_R"):
        return next((r.get(key) for r in t1 if r["method"] == method and r["split"] == split), None)

    lines = []
    for split in ("test", "test_subjects", "eval_subset"):
        ours, nn = get("OperatorNet (Int+Ext)", split), get("Nearest neighbour (Int+Ext)", split)
        if ours is not None and nn is not None:
            ratio = nn / ours
            lines.append(
                f"- {_SPLIT_NAMES[split]}: NN's d_R / OperatorNet (Int+Ext)'s = {ratio:.1f} "
                f"({_fmt(nn, 1e4)} vs {_fmt(ours, 1e4)} ×10⁻⁴; target ≥ 10 at `default`, the paper 23): "
                f"{'met' if ratio >= 10 else 'missed'}."
            )
    dv, de = get("OperatorNet (Int+Ext)", "test", "d_V"), get("OperatorNet (Int+Ext)", "test", "d_E")
    if dv is not None:
        lines.append(
            f"- test: d_V {_fmt(dv)} (target ≤ 0.014: {'met' if dv <= 0.014 else 'missed'}), "
            f"d_E {_fmt(de)} (target ≤ 0.045: {'met' if de <= 0.045 else 'missed'})."
        )
    paper, ours = get("OperatorNet (Int+Ext)", "test"), get(next(iter(OURS)), "test")
    if paper is not None and ours is not None:
        lines.append(
            f"- test: OperatorNet (Int+Ext)'s d_R / ours = {paper / ours:.2f} ({_fmt(paper, 1e4)} vs "
            f"{_fmt(ours, 1e4)} ×10⁻⁴; target ≥ 1.5 at `default`): {'met' if paper / ours >= 1.5 else 'missed'}."
        )
    for name in ("OperatorNet (Int+Ext)", next(iter(OURS))):
        refined, before = get(f"{name} + refinement", "test"), get(f"{name} + refinement", "test", "d_R_before")
        if refined is not None and before is not None:
            lines.append(
                f"- test: refinement changes {name}'s d_R by {100 * (refined / before - 1):+.0f} % "
                f"({_fmt(before, 1e4)} → {_fmt(refined, 1e4)} ×10⁻⁴ on the same shapes)."
            )
    truth = get("OperatorNet (Int+Ext)", "test")
    for name, channels in COMP.items():
        comp, same = get(name, "test"), get(f"OperatorNet ({channel_label(channels)})", "test")
        if comp is not None and truth is not None:
            paper = PAPER_TABLE1[name][0] / PAPER_TABLE1["OperatorNet (Int+Ext)"][0]
            alike = f"; {comp / same:.1f}× OperatorNet ({channel_label(channels)})'s" if same is not None else ""
            lines.append(
                f"- test: {name}'s d_R / OperatorNet (Int+Ext)'s (ground-truth maps) = {comp / truth:.1f} "
                f"({_fmt(comp, 1e4)} vs {_fmt(truth, 1e4)} ×10⁻⁴; target ≤ 5 at `default`, the paper "
                f"{paper:.1f}{alike}): {'met' if comp / truth <= 5 else 'missed'}."
            )
    order = [get(f"OperatorNet ({c})", "test") for c in ("Int+Ext", "Ext", "Int")]
    if None not in order:
        holds = order[0] < order[1] < order[2]
        lines.append(
            f"- ordering Int+Ext < Ext < Int on test (the paper's): {'holds' if holds else 'does not hold'} "
            f"({' / '.join(_fmt(v, 1e4) for v in order)})."
        )
    return lines


def _figures(out: Path, coll, ours, nn, histories: dict) -> None:
    """Training curves, and reconstructions by ``ours`` and ``nn`` (:class:`Method`) coloured by error."""
    plt = require("matplotlib.pyplot", "opnet.reproduce's figures")

    from .plotting import headless, plot_history, plot_reconstructions

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
        )
        plotter.screenshot(str(fig_dir / f"reconstructions_{split}.png"))
        plotter.close()


def refinement_curves(coll, idx, inits: dict, steps: int, snapshot_steps=(), *, device="cpu") -> tuple[dict, dict]:
    """Run :func:`opnet.reconstruct` (settings :data:`REFINE`) on shapes ``idx`` from each start in ``inits``
    (name → ``"base"`` or vertices ``(len(idx), n, 3)``), recording after every step the mean relative operator
    mismatch and the mean ``d_R``. Returns ``curves`` (name → ``step``, ``mismatch``, ``d_R`` lists, for
    :func:`opnet.plotting.plot_refinement_curves`) and ``snapshots`` (name → step → vertices of the first shape).
    """
    from .geometric import reconstruct
    from .metrics import d_R

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
            coll.operators[idx][:, _select(REFINE["channels"])],
            coll.base_basis,
            init=init,
            steps=steps,
            callback=record,
            progress=False,
            batch_size=len(idx),
            device=device,
            **REFINE,
        )  # one batch: one curve
        curves[name], snapshots[name] = c, snap
    return curves, snapshots


def snapshot_steps(steps: int) -> list[int]:
    """The steps shown in refinement figures: 0, 10, 100, ... up to ``steps``, and ``steps`` itself."""
    return sorted({s for s in (0, 10, 100, 1000) if s <= steps} | {steps})


def _refinement_figures(out: Path, coll, net_method, budget: Budget, device) -> None:
    """``refinement_curves.png`` (mismatch and d_R over the steps, from the base and from the network, on up to 8
    test shapes) and ``refinement_steps.png`` (one shape after 0, 10, 100... steps, coloured by error).
    """
    plt = require("matplotlib.pyplot", "opnet.reproduce's figures")

    from .plotting import headless, plot_reconstructions, plot_refinement_curves

    idx = test_set_indices(coll, "test")
    idx = evenly_spaced(idx, 8)
    shown = snapshot_steps(budget.refine_steps)
    curves, snaps = refinement_curves(
        coll,
        idx,
        {"from the base (geometric)": "base", f"from {net_method.name}": net_method.reconstruct(idx)},
        budget.refine_steps,
        shown,
        device=device,
    )
    fig = plot_refinement_curves(curves)
    fig.savefig(out / "figures" / "refinement_curves.png", dpi=120)
    plt.close(fig)
    headless()
    name = f"from {net_method.name}"
    plotter = plot_reconstructions(
        coll.vertices[idx[:1]], {f"step {s}": snaps[name][s][None] for s in shown}, coll.faces, titles=["refined"]
    )
    plotter.screenshot(str(out / "figures" / "refinement_steps.png"))
    plotter.close()
