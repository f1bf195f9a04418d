"""The pipeline behind ``python -m opnet reproduce``: data → Table 1 and the ablation → results.json/md, figures.

:func:`reproduce` builds (or reuses) the human collection of a preset, trains the networks it needs, each
in its own run directory under ``OUT/runs/`` (a second call skips finished runs, an interrupted one
continues from its last epoch), evaluates them beside the nearest-neighbour and base-shape baselines,
and writes (keeping the rows of an earlier call into ``OUT`` that this one does not measure again,
:func:`opnet.experiments.report.merge_results`: a call with ``ablation=False`` leaves the ablation's rows there)

- ``OUT/results.json``: ``{"format", "version", "context", "rows"}`` (:func:`read_results` reads it): the
  machine, data and budget, and the rows ``{"table", "method", "channels", "depth", "split", "d_R", "d_V",
  "d_E"`` (means; ``*_median`` too), ``"n_shapes", "epochs", "train_seconds", "preset", "device"}``
  with ``d_R`` in m² (the paper reports it ×10⁻⁴); a network's rows also hold its run's structured fields
  (``"run", "architecture", "variant", "group"``), a baseline's ``"baseline"`` (``"nearest_neighbour"``,
  ``"base_shape"``, ``"geometric"``), a refined network's its run's and ``"refined"``: the report
  (``opnet.experiments.report``) finds rows by these, ``"method"`` is only shown;
- ``OUT/results.md``: Table 1 and the ablation laid out like the paper's, with its numbers beside ours;
- ``OUT/figures/``: training curves, the ablation heat map, reconstructions coloured by per-vertex error, and the
  applications' interpolation strips and analogy grids.

With ``maps=True`` (default) it also computes maps from the 2k-vertex version of every shape onto the base
(:func:`opnet.data.mapped_collection`), trains Table 1's "Comp" rows on the operators through them (:data:`COMP`),
and reconstructs test shapes given on other triangulations (:func:`discretisation_rows`: rows with ``"table"``
``"discretisation"``, and ``OUT/figures/discretisation.png``). With ``maps`` or ``bodies`` (default for the humans),
the rows beside Table 1 for generalisation (:func:`generalisation_rows`) and ``OUT/figures/generalisation.png``
(:func:`generalisation_figure`).

With ``applications=True`` (default) it also trains the PointNet autoencoder (a Table 1 row) and runs the
ground-truth analogy and interpolation benchmarks of :mod:`opnet.apps` (rows with ``"table"`` ``"analogy"`` and
``"interpolation"``). Table 1, the applications and ``results.*`` are written before the ablation.

This module declares the runs (:func:`spec`, :data:`TABLE1`, :data:`COMP`, the ablation's grid...) and hands them
to the runner (``opnet.experiments``); the report, the figures and the paper's numbers live in
``opnet.experiments.report``, ``opnet.experiments.figures`` and ``opnet.experiments.paper`` (their public names are
importable from here too).
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from . import __version__
from ._checks import check_int
from ._extras import require
from .evaluate import (
    TEST_SETS,
    base_shape_method,
    ensemble_method,
    evaluate,
    evenly_spaced,
    geometric_method,
    nearest_neighbour_method,
    operatornet_method,
    pointnet_method,
    refined_method,
    test_set_indices,
    test_sets_for,
)
from .experiments import figures as _figures
from .experiments.figures import (
    ablation_figure,
    application_figures,
    discretisation_figure,
    generalisation_figure,
    refinement_figures,
    snapshot_steps,
    table1_figures,
)
from .experiments.paper import PAPER_ABLATION, PAPER_ABLATION_DEPTHS, PAPER_ABLATION_SETS, PAPER_TABLE1
from .experiments.report import (
    ablation_table,
    applications_markdown,
    discretisation_markdown,
    merge_results,
    read_results,
    results_markdown,
    targets,
    write_results,
)
from .experiments.shipped import COLLECTIONS  # the generated collections reproduce runs on (and ships)
from .shape_difference import KINDS

__all__ = [
    "reproduce",
    "run_path",
    "notebook_out",
    "TRAINING_FIELDS",
    "spec",
    "table1_specs",
    "comp_specs",
    "ablation_specs",
    "table1_networks",
    "comp_networks",
    "discretisation_rows",
    "discretisation_indices",
    "discretisation_figure",
    "generalisation_figure",
    "application_methods",
    "applications_rows",
    "applications_markdown",
    "discretisation_markdown",
    "ablation_table",
    "results_markdown",
    "read_results",
    "targets",
    "write_results",
    "refinement_curves",
    "snapshot_steps",
    "Budget",
    "BUDGETS",
    "TABLE1",
    "OURS",
    "COMP",
    "COMP_RESOLUTION",
    "COMP_HALF",
    "COMP_THREE",
    "MORE_BODIES",
    "bodies_specs",
    "bodies_group",
    "bodies_networks",
    "generalisation_rows",
    "DISCRETISATIONS",
    "DISCRETISATION_NETWORKS",
    "POINTNET",
    "COLLECTIONS",
    "default_out",
    "REFINE",
    "REFINE_SETS",
    "FUNCCHAR",
    "funcchar_method",
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


#: The fields of a :class:`Budget` that the networks are trained with (the others set how much is evaluated).
TRAINING_FIELDS = ("epochs", "ablation_epochs", "pointnet_epochs", "batch_size", "lr", "hidden")
#: The training settings (:class:`Budget`) of each preset.
BUDGETS = {
    "quick": Budget(
        epochs=60,
        ablation_epochs=6,
        batch_size=16,
        refine_steps=30,
        refine_shapes=12,
        pointnet_epochs=20,
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
#: The ablation's columns (Appendix B, in the paper's order) and rows: the paper's grid, which the report lays out
#: beside its numbers (``opnet.experiments.paper.PAPER_ABLATION_SETS``).
ABLATION_SETS = PAPER_ABLATION_SETS
#: The ablation's encoder depths (its rows; ``opnet.experiments.paper.PAPER_ABLATION_DEPTHS``).
ABLATION_DEPTHS = PAPER_ABLATION_DEPTHS

#: This project's variant (:data:`opnet.model.VARIANTS` ``["ours"]``), trained like Table 1's networks.
OURS = {"OperatorNet ours (Int+Ext)": KINDS}
#: The operator-matching rows (:func:`opnet.reconstruct`): its settings, chosen on ``val`` (``docs/results.md``), and
#: the test sets they are evaluated on (at most ``Budget.refine_shapes`` shapes of each).
REFINE = dict(channels=("area", "extrinsic"), optimizer="lbfgs", smoothness=1.0)
#: The test sets on which the operator-matching rows are evaluated.
REFINE_SETS = ("test", "test_subjects")
#: FuncChar's full set of channels (Corman et al. 2017): the area and conformal operators of the shape and of its
#: offset surface (:class:`opnet.inner_products.OffsetAreaInnerProduct`, ``OffsetConformalInnerProduct``). Its Table 1
#: row, ``"FuncChar (Int+Ext)"``, reconstructs from the base by matching them (:func:`funcchar_method`).
FUNCCHAR = ("area", "conformal", "offset_area", "offset_conformal")

#: Table 1's "Comp" rows: OperatorNet trained and tested on operators through maps computed from each shape's
#: :data:`COMP_RESOLUTION` mesh (:func:`opnet.matching.compute_map`), not the known correspondence.
COMP = {"OperatorNet (Comp)(Int+Ext)": KINDS, "OperatorNet (Comp)(Ext)": ("extrinsic",)}
#: The mesh (:data:`opnet.data.humans.RESOLUTIONS`) whose computed maps the "Comp" rows use.
COMP_RESOLUTION = "2k"
#: Rows beside Table 1's "Comp" rows, for other triangulations (the docs' results page, "Generalisation"): the paper's
#: network trained on half the training shapes through the :data:`COMP_RESOLUTION` computed maps and half with their
#: exact operators (:func:`opnet.data.half_mapped`), chosen on ``val`` by ``benchmarks/generalisation.py``: name →
#: channels. Tested like the "Comp" rows, and decoded in the different-discretisation rows too.
COMP_HALF = {"OperatorNet (Comp + 1k)(Ext)": ("extrinsic",)}
#: Beside them too, for the 5k meshes: the paper's network trained on a third of the training shapes with their exact
#: operators, a sixth through maps computed from their 5k meshes and the rest through the :data:`COMP_RESOLUTION`
#: maps (:func:`opnet.data.three_way_mapped`), chosen on ``val`` by ``benchmarks/generalisation.py``: name →
#: channels. Its 5k maps take seconds per shape (a sixth of the training shapes), computed once and cached.
COMP_THREE = {"OperatorNet (Comp + 5k + 1k)(Ext)": ("extrinsic",)}
#: Rows beside Table 1 for unseen bodies (the docs' results page, "Generalisation"): this project's variant trained on
#: the collection with more distinct bodies among its training shapes (:func:`opnet.data.load_collection`'s
#: ``bodies``, and ``poses``: more random poses; the held-out shapes are the same), chosen on the validation bodies by
#: ``benchmarks/generalisation.py``: name → the collection's draws (``load_collection``'s keywords) and, for an
#: ensemble (:func:`opnet.evaluate.ensemble_method`) of the networks trained with seeds 0, 1, ..., their count
#: (``seeds``). A row holds these fields.
MORE_BODIES = {
    "OperatorNet ours, a body per shape (Int+Ext)": {"bodies": "shape"},
    "OperatorNet ours, a body per shape, more random poses, 2 seeds (Int+Ext)": {
        "bodies": "shape",
        "poses": "quarter",
        "seeds": 2,
    },
}
#: The different-discretisation rows: test shapes on these meshes, mapped onto the 1k base by these maps.
DISCRETISATIONS = (("2k", "true"), ("2k", "computed"), ("5k", "true"), ("5k", "computed"))
#: The networks that decode them (Table 1's and :data:`COMP`'s names; :func:`generalisation_rows` adds
#: :data:`COMP_HALF`'s and :data:`COMP_THREE`'s).
DISCRETISATION_NETWORKS = ("OperatorNet (Int+Ext)", "OperatorNet (Ext)", *COMP)


#: Table 1's name of the PointNet autoencoder (:class:`opnet.model.PointNetAutoencoder`), trained with ``applications``.
POINTNET = "PointNet AE"


def default_out(preset: str, collection: str = "humans") -> Path:
    """The folder :func:`reproduce` writes into when not given one: ``reproduce-<preset>`` for the humans,
    ``reproduce-<collection>-<preset>`` otherwise.
    """
    return Path(f"reproduce-{preset}" if collection == "humans" else f"reproduce-{collection}-{preset}")


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
    maps: bool | None = None,
    bodies: bool | None = None,
    collection: str = "humans",
    budget: Budget | None = None,
    data_root=None,
    progress: bool | None = None,
) -> list[dict]:
    """Reproduce the paper's Table 1 and ablation on the generated humans (or animals) at ``preset``; returns the rows.

    Parameters
    ----------
    preset : ``"quick"`` (minutes on a laptop CPU), ``"default"`` or ``"paper"``.
    out : path, the output folder (default ``reproduce-<preset>``, ``reproduce-animals-<preset>`` for the animals);
        reused to resume. Its ``results.json`` keeps
        the rows of earlier calls (same preset and budget) that this call does not measure again, so the parts
        of a reproduction can be run one call at a time.
    device : ``"auto"`` (CUDA when available), ``"cpu"``, ``"cuda"``.
    ablation : also train and evaluate the depth × channels grid (Appendix B).
    figures : also write the figures (PNG) under ``out/figures``.
    refine : also evaluate the operator-matching rows: the geometric baseline, FuncChar (:func:`funcchar_method`:
        its offset channels are computed for the collection first) and OperatorNet + refinement
        (:func:`opnet.reconstruct` with :data:`REFINE`, ``budget.refine_steps`` steps, on at most
        ``budget.refine_shapes`` shapes of each of :data:`REFINE_SETS`, evenly spaced: they take seconds per shape).
    maps : also the computed-map rows (humans only; ``None``, the default: for the humans): Table 1's "Comp" networks
        (:func:`comp_networks`; computing the maps of the whole collection takes about 0.6 s per shape and core, done
        once and cached beside the collection) and the different-discretisation rows (:func:`discretisation_rows`,
        ``budget.discretisation_shapes`` test shapes).
    bodies : also the :data:`MORE_BODIES` rows (generated humans, heads, hands; ``None``, the default: for the humans):
        this project's variant trained with more distinct bodies (and random poses) among the training shapes
        (:func:`bodies_networks`; one row is an ensemble of two seeds), evaluated like Table 1's networks (and
        refined with them, with ``refine``).
    collection : one of :data:`~opnet.experiments.shipped.COLLECTIONS`: ``"humans"`` (the paper's Table 1 and its
        numbers beside ours) or ``"animals"`` (:mod:`opnet.data.animals`: the same networks and baselines; the
        analogies transfer pose and animal type, the interpolations go between species; the paper gives no numbers to
        set beside them).
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
    if collection not in COLLECTIONS:
        raise ValueError(f"unknown collection {collection!r}; reproduce runs on one of {list(COLLECTIONS)}.")
    if maps and collection != "humans":
        raise ValueError(
            f"the computed-map rows need the humans' 2k and 5k meshes; the {collection} have one mesh: pass "
            "maps=False (the command line's --no-maps)."
        )
    maps = collection == "humans" if maps is None else maps
    if bodies and collection == "animals":
        raise ValueError("the animals' bodies are blends of their species, not drawn: pass bodies=False (--no-bodies).")
    bodies = collection == "humans" if bodies is None else bodies
    budget = budget or BUDGETS[preset]
    out = Path(out if out is not None else default_out(preset, collection))
    if out.exists() and not out.is_dir():
        raise ValueError(f"out={out} is a file; give a folder.")
    (out / "runs").mkdir(parents=True, exist_ok=True)
    device = resolve_device(device)
    t_start = time.perf_counter()
    earlier = read_results(out) if (out / "results.json").is_file() else None  # kept where not measured again
    coll = load_collection(collection, preset, root=data_root, progress=progress)
    info = dict(preset=preset)

    from tqdm.auto import tqdm

    runs = tqdm(
        total=len(TABLE1)
        + len(OURS)
        + bool(applications)
        + (len(COMP) + len(COMP_HALF) + len(COMP_THREE) if maps else 0)
        + (len(bodies_specs(budget)) if bodies else 0)
        + (len(ABLATION_DEPTHS) * len(ABLATION_SETS) if ablation else 0),
        desc="reproduce",
        unit="network",
        disable=progress is False,
    )

    nets, histories, devices = table1_networks(
        coll, out, budget, pointnet=applications, device=device, progress=progress, bar=runs
    )
    specs = _declared_specs(budget)
    methods = [operatornet_method(nets[name], coll, name) for name in (*TABLE1, *OURS)]
    methods += [pointnet_method(nets[POINTNET], coll, POINTNET)] if applications else []
    for m in methods:
        m.info = dict(table="table1", **specs[m.name].fields(), **devices[m.name])
    if maps:
        comp, comp_nets, comp_histories, comp_devices = comp_networks(
            coll, out, budget, device=device, bar=runs, progress=progress, data_root=data_root
        )
        nets.update(comp_nets)
        histories.update(comp_histories)
        comp_methods = [operatornet_method(net, comp, name) for name, net in comp_nets.items()]
        for m in comp_methods:
            m.info = dict(table="table1", **specs[m.name].fields(), **comp_devices[m.name])
    baselines = [nearest_neighbour_method(coll, KINDS), base_shape_method(coll)]
    tags = [dict(baseline="nearest_neighbour"), dict(baseline="base_shape")]
    matching = []
    funcchar = []
    if refine:
        options = _refine_options(budget, device)
        matching = [geometric_method(coll, **options)]
        tags.append(dict(baseline="geometric"))
        refined = [m for m in methods if m.channels == KINDS]
        matching += [refined_method(m, coll, **options) for m in refined]
        tags += [specs[m.name].refined_fields() for m in refined]
        with_offsets = coll.with_kinds([*dict.fromkeys([*coll.kinds, *FUNCCHAR])], progress=False)
        funcchar = [funcchar_method(with_offsets, budget, device=device)]  # evaluated on with_offsets
        tags.append(dict(baseline="funcchar"))
    for m, tag in zip(baselines + matching + funcchar, tags, strict=True):
        m.info = _untrained_info(tag, device)
    rows = evaluate(coll, methods + baselines, test_sets_for(coll), extra=info)  # animals: also the unseen species
    rows += evaluate(comp, comp_methods, TEST_SETS, extra=info) if maps else []
    rows += evaluate(coll, matching, REFINE_SETS, extra=info)
    rows += evaluate(with_offsets, funcchar, REFINE_SETS, extra=info) if funcchar else []
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
    if bodies or maps:
        rows += generalisation_rows(
            coll,
            out,
            budget,
            bodies=bodies,
            maps=maps,
            refine=refine,
            device=device,
            data_root=data_root,
            progress=progress,
            bar=runs,
            extra=info,
            comp=comp if maps else None,
        )
    context = dict(
        preset=preset,
        data=collection,
        budget=asdict(budget),
        machine=_machine(device),
        date=time.strftime("%Y-%m-%d"),
        opnet_version=__version__,
        collection=repr(coll),
        splits={s: int(np.sum(coll.split == s)) for s in ("train", "val", "test", "test_subjects")},
        eval_subset=int(len(coll.eval_subset)),
    )

    def save(rows):  # results.json/md: this call's rows, and an earlier call's that it did not measure again
        merged, merged_context = merge_results(earlier, rows, context)
        write_results(out, merged, merged_context, time.perf_counter() - t_start)
        return merged

    save(rows)
    if figures:
        table1_figures(
            out,
            coll,
            methods[0],
            baselines[0],
            histories,
        )
        if refine:
            refinement_figures(out, coll, methods[0], budget.refine_steps, device=device, **REFINE)
    if applications:
        algebras = application_methods(coll, nets, budget, refine=refine, device=device)
        rows += applications_rows(coll, algebras, budget, out=out / "figures" if figures else None, progress=progress)
        save(rows)

    if ablation:
        for s in ablation_specs(budget):
            net, _, run_info = _train(coll, out, s, device=device, progress=progress, bar=runs)
            m = operatornet_method(net, coll, s.label)
            m.info = dict(table="ablation", **s.fields(), **run_info)
            rows += evaluate(coll, [m], ("test",), extra=info)
    rows = save(rows)
    drawn = {"ablation": ablation_figure} if ablation else {}
    drawn |= {"generalisation": generalisation_figure} if bodies or maps else {}
    if figures and drawn:
        plt = require("matplotlib.pyplot", "opnet.reproduce's figures")
        for name, draw in drawn.items():
            fig = draw(rows)
            fig.savefig(out / "figures" / f"{name}.png", dpi=120)
            plt.close(fig)
    runs.close()
    return rows


def funcchar_method(coll, budget: Budget, *, device="cpu"):
    """FuncChar's reconstruction (the paper's "FuncChar (Int+Ext)" row): :func:`opnet.reconstruct` from the base
    shape, matching the :data:`FUNCCHAR` operators with :data:`REFINE`'s optimiser and smoothness,
    ``budget.refine_steps`` steps, on at most ``budget.refine_shapes`` shapes per test set; an
    :class:`opnet.evaluate.Method` of ``coll``, which must hold the :data:`FUNCCHAR` channels
    (``coll.with_kinds([*coll.kinds, "offset_area", "offset_conformal"])`` computes them and caches them beside it).
    """
    from .evaluate import base_shape_method, refined_method

    missing = [name for name in FUNCCHAR if name not in coll.kinds]
    if missing:
        raise ValueError(
            f"FuncChar matches the channels {FUNCCHAR}; this collection lacks {missing}: pass "
            f"coll.with_kinds([*coll.kinds, {', '.join(map(repr, missing))}])."
        )
    options = dict(REFINE, channels=FUNCCHAR, steps=budget.refine_steps, device=device)
    return refined_method(
        base_shape_method(coll), coll, max_shapes=budget.refine_shapes, name="FuncChar (Int+Ext)", **options
    )


def spec(
    table: str,
    budget: Budget,
    channels=KINDS,
    depth: int = 1,
    variant: str = "paper",
    *,
    epochs=None,
    name=None,
    options=None,
):
    """The declared run (:class:`opnet.experiments.RunSpec`) of one network of the reproduction: ``table`` is its
    group (``"table1"``, ``"comp"``, ``"ablation"``...), ``variant`` ``"paper"``, ``"ours"`` or ``"pointnet"`` (the
    PointNet autoencoder: ``budget.pointnet_epochs``); the budget's batch size, learning rate and width; ``options``:
    other options of :func:`opnet.train.fit`.
    """
    from .experiments import RunSpec

    pointnet = variant == "pointnet"
    return RunSpec(
        channels=() if pointnet else channels,
        depth=depth,
        variant="paper" if pointnet else variant,
        architecture="pointnet" if pointnet else "operatornet",
        epochs=epochs or (budget.pointnet_epochs if pointnet else budget.epochs),
        batch_size=budget.batch_size,
        lr=budget.lr,
        hidden=budget.hidden,
        group=table,
        name=name,
        options=dict(options or {}),
    )


def _declared_specs(budget: Budget) -> dict:
    """Name → declared run (:class:`opnet.experiments.RunSpec`) of Table 1's networks (:func:`table1_specs`,
    :func:`comp_specs`, :func:`bodies_specs`).
    """
    specs = (
        *table1_specs(budget),
        *comp_specs(budget),
        *comp_specs(budget, beside="half"),
        *comp_specs(budget, beside="three"),
        *bodies_specs(budget),
    )
    return {s.name: s for s in specs}


def _train(coll, out, spec, *, device, progress, bar=None):
    """Train (or load, when finished) one declared network of the reproduction in ``out/runs/``."""
    from .experiments import train_run

    if bar is not None:
        bar.set_postfix_str(spec.run_name)
    run = train_run(spec, coll, Path(out) / "runs", device=device, progress=progress is True)
    if bar is not None:
        bar.update(1)
    return run.net, run.history, run.info


def table1_networks(
    coll, out, budget: Budget, *, pointnet: bool = True, device="cpu", progress=None, bar=None
) -> tuple[dict, dict, dict]:
    """Table 1's networks (:data:`TABLE1`, :data:`OURS` and, with ``pointnet``, :data:`POINTNET`), trained in
    ``out/runs/`` or loaded when already trained there: dicts name → network, name → history, name → run info
    (``epochs``, ``train_seconds``, ``device``). :func:`reproduce` and the notebooks share them this way.
    """
    nets, histories, info = {}, {}, {}
    for s in table1_specs(budget, pointnet=pointnet):
        nets[s.name], histories[s.name], info[s.name] = _train(coll, out, s, device=device, progress=progress, bar=bar)
    return nets, histories, info


def table1_specs(budget: Budget, *, pointnet: bool = True) -> list:
    """Table 1's declared runs: :data:`TABLE1` (the paper's network), :data:`OURS` and, with ``pointnet``,
    :data:`POINTNET`, each named by its Table 1 row.
    """
    specs = [spec("table1", budget, channels, name=name) for name, channels in TABLE1.items()]
    specs += [spec("table1", budget, channels, variant="ours", name=name) for name, channels in OURS.items()]
    return specs + ([spec("table1", budget, variant="pointnet", name=POINTNET)] if pointnet else [])


def ablation_specs(budget: Budget) -> list:
    """The ablation's declared runs: every set of :data:`ABLATION_SETS` at every depth of :data:`ABLATION_DEPTHS`,
    for ``budget.ablation_epochs``.
    """
    return [
        spec(
            "ablation",
            budget,
            channels,
            depth,
            epochs=budget.ablation_epochs,
            name=f"OperatorNet ({label}) depth {depth}",
        )
        for depth in ABLATION_DEPTHS
        for label, channels in ABLATION_SETS.items()
    ]


def comp_networks(coll, out, budget: Budget, *, device="cpu", progress=None, bar=None, data_root=None) -> tuple:
    """Table 1's "Comp" networks (:data:`COMP`), trained in ``out/runs/comp-*`` (or loaded when trained there) on
    ``comp = opnet.data.mapped_collection(coll, COMP_RESOLUTION)``: the same shapes, with operators through maps
    computed from their 2k-vertex meshes. Returns ``comp`` and, like :func:`table1_networks`, dicts name →
    network, name → history, name → run info.
    """
    from .data import mapped_collection

    comp = mapped_collection(coll, COMP_RESOLUTION, "computed", root=data_root, progress=progress)
    nets, histories, info = {}, {}, {}
    for s in comp_specs(budget):
        nets[s.name], histories[s.name], info[s.name] = _train(comp, out, s, device=device, progress=progress, bar=bar)
    return comp, nets, histories, info


def comp_specs(budget: Budget, *, beside: str | None = None) -> list:
    """Table 1's "Comp" declared runs (:data:`COMP`, group ``"comp"``), each named by its Table 1 row; with ``beside``
    ``"half"`` or ``"three"``, the runs beside them instead (:data:`COMP_HALF`, group ``"comp-half"``;
    :data:`COMP_THREE`, group ``"comp-three"``).
    """
    rows = {None: COMP, "half": COMP_HALF, "three": COMP_THREE}
    if beside not in rows:
        raise ValueError(f"beside must be None, 'half' or 'three', got {beside!r}.")
    group = "comp" if beside is None else f"comp-{beside}"
    return [spec(group, budget, channels, name=name) for name, channels in rows[beside].items()]


def bodies_group(bodies: str, poses: str = "sequence") -> str:
    """The :class:`~opnet.experiments.RunSpec` group of a run trained on ``load_collection(..., bodies=, poses=)``:
    ``"bodies-<bodies>"``, then ``"-poses-<poses>"`` unless the poses are the design's.
    """
    return f"bodies-{bodies}" + ("" if poses == "sequence" else f"-poses-{poses}")


def bodies_specs(budget: Budget) -> list:
    """The declared runs of :data:`MORE_BODIES` (this project's variant, group :func:`bodies_group`: trained on
    ``load_collection(..., bodies=, poses=)``), each named by its row; an ensemble's further seeds by its row and
    ``", seed <s>"``.
    """
    return [s for seeds in _bodies_members(budget).values() for s in seeds]


def _bodies_members(budget: Budget) -> dict:
    """Each :data:`MORE_BODIES` row's declared runs, one per seed: name → list of specs."""
    out = {}
    for name, entry in MORE_BODIES.items():
        first = spec(bodies_group(**_draws(entry)), budget, KINDS, variant="ours", name=name)
        out[name] = [
            first,
            *(replace(first, seed=s, name=f"{name}, seed {s}") for s in range(1, entry.get("seeds", 1))),
        ]
    return out


def _draws(entry: dict) -> dict:
    """The ``load_collection`` keywords of a :data:`MORE_BODIES` entry."""
    return {k: v for k, v in entry.items() if k in ("bodies", "poses")}


def bodies_networks(coll, out, budget: Budget, *, device="cpu", progress=None, bar=None, data_root=None) -> tuple:
    """The :data:`MORE_BODIES` networks, trained in ``out/runs/bodies-*`` (or loaded when trained there), each on the
    generated collection ``coll`` with other bodies (and poses) among its training shapes (``bodies=``, ``poses=``; the
    held-out shapes are ``coll``'s, checked): dicts name → its networks (one per seed), name → their histories,
    name → run info (the first seed's, with the seeds' summed ``train_seconds``, the entry's fields and, for an
    ensemble, ``run``: its seeds' run names joined by ``+``).
    """
    from .data import load_collection

    meta = coll.meta
    nets, histories, info = {}, {}, {}
    for name, specs in _bodies_members(budget).items():
        draws = _draws(MORE_BODIES[name])
        more = load_collection(
            meta["name"],
            meta["preset"],
            data_root,
            resolution=meta["resolution"],
            seed=meta["seed"],
            progress=progress,
            **draws,
        )
        held = coll.split != "train"
        if not (np.array_equal(more.split, coll.split) and np.array_equal(more.vertices[held], coll.vertices[held])):
            raise ValueError(f"the collection with {draws} does not hold {coll!r}'s held-out shapes.")
        trained = [_train(more, out, s, device=device, progress=progress, bar=bar) for s in specs]
        nets[name], histories[name] = [t[0] for t in trained], [t[1] for t in trained]
        seconds = sum(t[2]["train_seconds"] for t in trained)
        info[name] = dict(trained[0][2], train_seconds=seconds, **MORE_BODIES[name])
        if len(specs) > 1:  # an ensemble is a method of its own: its rows are told apart from its first seed's
            info[name]["run"] = "+".join(s.run_name for s in specs)
    return nets, histories, info


def _refine_options(budget: Budget, device) -> dict:
    """The operator-matching options of Table 1's refinement rows and the geometric baseline at ``budget``."""
    return dict(REFINE, steps=budget.refine_steps, max_shapes=budget.refine_shapes, device=device)


def _untrained_info(fields: dict, device) -> dict:
    """The ``info`` of a Table 1 row that trains nothing of its own (a baseline, a refinement): ``fields`` and the
    device, no epochs or training time.
    """
    return dict(table="table1", **fields, epochs=None, train_seconds=None, device=str(device))


def generalisation_rows(
    coll,
    out,
    budget: Budget,
    *,
    bodies: bool = True,
    maps: bool = True,
    refine: bool = True,
    device="cpu",
    data_root=None,
    progress=None,
    bar=None,
    extra: dict | None = None,
    comp=None,
) -> list[dict]:
    """The rows beside Table 1 for generalisation (the docs' results page, "Generalisation"), their networks trained
    in ``out/runs/`` (or loaded when trained there).

    With ``bodies``: the :data:`MORE_BODIES` networks (:func:`bodies_networks`; an ensemble's averaged,
    :func:`opnet.evaluate.ensemble_method`) on ``coll``'s test sets (rows like Table 1's, with the entry's ``bodies``,
    ``poses``, ``seeds``) and, with ``refine``, refined by :func:`opnet.reconstruct` like Table 1's networks
    (:data:`REFINE`, on :data:`REFINE_SETS`). With ``maps``: the :data:`COMP_HALF` networks, trained on half the
    training shapes through the "Comp" rows' maps (:data:`COMP_RESOLUTION`) and half exact
    (:func:`opnet.data.half_mapped`), and the :data:`COMP_THREE` ones (a third exact, a sixth through 5k maps:
    :func:`opnet.data.three_way_mapped`), on the "Comp" rows' test sets and in the different-discretisation rows
    (:func:`discretisation_rows`). ``comp``: the :func:`comp_networks` collection, reused (loaded when ``None``).
    """
    from .data import half_mapped, mapped_collection, three_way_mapped

    specs, rows = _declared_specs(budget), []

    def described(methods, info):
        for m in methods:
            m.info = {"table": "table1", **specs[m.name].fields(), **info[m.name]}
        return methods

    if bodies:
        nets, _, info = bodies_networks(
            coll, out, budget, device=device, progress=progress, bar=bar, data_root=data_root
        )
        methods = []
        for name, members in nets.items():  # one network, or the ensemble of its seeds'
            each = [operatornet_method(net, coll, name) for net in members]
            methods.append(each[0] if len(each) == 1 else ensemble_method(each, name))
        methods = described(methods, info)
        rows += evaluate(coll, methods, TEST_SETS, extra=extra)
        if refine:
            refined = [refined_method(m, coll, **_refine_options(budget, device)) for m in methods]
            for m, name in zip(refined, nets, strict=True):
                fields = {**specs[name].refined_fields(), **MORE_BODIES[name], "run": info[name].get("run")}
                m.info = _untrained_info({k: v for k, v in fields.items() if v is not None}, device)
            rows += evaluate(coll, refined, REFINE_SETS, extra=extra)
    if maps:
        if comp is None:
            comp = mapped_collection(coll, COMP_RESOLUTION, "computed", root=data_root, progress=progress)
        mixed = {
            "half": lambda: half_mapped(coll, comp),
            "three": lambda: three_way_mapped(coll, comp, "5k", root=data_root, progress=progress),
        }
        nets, info = {}, {}
        for beside, data in mixed.items():
            trained_on = data()
            for s in comp_specs(budget, beside=beside):
                nets[s.name], _, info[s.name] = _train(trained_on, out, s, device=device, progress=progress, bar=bar)
        methods = described([operatornet_method(net, comp, name) for name, net in nets.items()], info)
        rows += evaluate(comp, methods, TEST_SETS, extra=extra)
        rows += discretisation_rows(coll, nets, budget, comp=comp, data_root=data_root, progress=progress, extra=extra)
    return rows


def discretisation_rows(
    coll, nets: dict, budget: Budget, *, comp=None, data_root=None, progress=None, out=None, extra: dict | None = None
) -> list[dict]:
    """Reconstructions of test shapes given on other triangulations: rows with ``"table"`` ``"discretisation"``.

    At most ``budget.discretisation_shapes`` shapes of ``test`` (evenly spaced, :func:`discretisation_indices`) are
    generated on each mesh of :data:`DISCRETISATIONS` and mapped onto the base by the true or the computed map
    (:func:`opnet.data.mapped_collection`), and, as a reference, taken with their exact 1k operators (``resolution``
    ``"1k"``, ``maps`` ``"exact"``). Every network of ``nets`` (name → network) decodes every encoding; d_R, d_V,
    d_E against the generator's 1k shapes. Rows also hold ``resolution``, ``maps`` and ``map_error`` (metres, mean
    over the shapes; 0 for the true map) and, for a network of Table 1's names (:data:`TABLE1`, :data:`COMP`), its
    run's structured fields (``run``, ``architecture``, ``variant``, ``group``...). ``comp``: the
    :func:`comp_networks` collection, whose 2k computed maps are reused. With ``out``, writes ``discretisation.png``
    there (:func:`discretisation_figure` of three 5k shapes).
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
    rows, specs = [], _declared_specs(budget)
    for (res, maps), c in encodings.items():
        error = float(np.mean(c.params["map_error"])) if "map_error" in c.params else 0.0
        methods = [operatornet_method(net, c, name) for name, net in nets.items()]
        for m in methods:
            run = specs[m.name].fields() if m.name in specs else {}
            m.info = dict(table="discretisation", **run, resolution=res, maps=maps, map_error=error)
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


def run_path(out, table: str, channels, depth: int = 1, variant: str = "paper") -> Path:
    """The run directory :func:`reproduce` uses for one network: ``out/runs/<table>-<channels>-d<depth>``
    (:attr:`opnet.experiments.RunSpec.run_name` of :func:`spec`).

    ``table`` is ``"table1"``, ``"comp"`` or ``"ablation"``; ``channels`` any channels (a set of built-ins goes by its
    short name ``A+E+C``, ``Ext``...); ``variant="ours"`` adds ``-ours``; ``variant="pointnet"`` names the PointNet
    autoencoder's run, ``out/runs/<table>-pointnet`` (``channels`` and ``depth`` are then ignored).
    """
    if out is None:
        raise TypeError("out must be the reproduction's folder (its runs/ hold the networks), not None.")
    return spec(table, BUDGETS["quick"], channels, depth, variant).run_dir(Path(out) / "runs")


def notebook_out(preset: str, root=None) -> Path:
    """The reproduction folder the notebooks share at ``preset`` (its ``runs/`` hold their networks):
    ``<root>/reproduce-<preset>-<digest>``, ``root`` by default :func:`opnet.data.default_root`, the digest 8 hex
    digits of SHA-256 over the fields of ``BUDGETS[preset]`` that the networks are trained with
    (:data:`TRAINING_FIELDS`). A release that changes a preset's training budget trains its networks in a new
    folder, beside those of the old budget (a run directory refuses to resume a run of other settings:
    :class:`opnet.train.CheckpointError`); the old folder can be deleted.
    """
    from .data import default_root

    if preset not in BUDGETS:
        raise ValueError(f"unknown preset {preset!r}; use one of {list(BUDGETS)}.")
    fields = {name: getattr(BUDGETS[preset], name) for name in TRAINING_FIELDS}
    digest = hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:8]
    return Path(default_root() if root is None else root) / f"reproduce-{preset}-{digest}"


def application_methods(coll, nets: dict, budget: Budget, *, refine: bool = True, device="cpu") -> list:
    """The applications' methods (:class:`opnet.apps.ShapeAlgebra`): Table 1's OperatorNet (Int+Ext) with the
    multiplicative and the linear algebra, our variant, the first + refinement (:data:`REFINE`, at most
    ``budget.apps_refine_shapes`` shapes per kind), the PointNet AE and NN. ``nets``: Table 1's name → network.

    Each method carries ``row_fields``, the structured fields :func:`applications_rows` gives its rows: its
    network's run fields (``run``, ``architecture``, ``variant``, ``channels``, ``depth``, ``group``; with
    ``refined`` for the refined one), or ``baseline`` ``"nearest_neighbour"``.
    """
    from . import apps

    specs = _declared_specs(budget)
    paper_name, ours_name = "OperatorNet (Int+Ext)", next(iter(OURS))
    paper, ours = nets[paper_name], nets[ours_name]
    methods = [
        (apps.operatornet_algebra(paper, coll), specs[paper_name].fields()),
        (apps.operatornet_algebra(paper, coll, scheme="linear"), specs[paper_name].fields()),
        (apps.operatornet_algebra(ours, coll, name="OperatorNet ours (mult.)"), specs[ours_name].fields()),
    ]
    if refine:
        refined = apps.operatornet_algebra(
            paper,
            coll,
            refine=dict(REFINE, steps=budget.refine_steps, device=device),
            max_shapes=budget.apps_refine_shapes,
        )
        methods.append((refined, specs[paper_name].refined_fields()))
    methods += [
        (apps.pointnet_algebra(nets[POINTNET], coll), specs[POINTNET].fields()),
        (apps.nearest_neighbour_algebra(coll), dict(baseline="nearest_neighbour")),
    ]
    for m, tag in methods:
        m.row_fields = tag
    return [m for m, _ in methods]


def applications_rows(coll, methods, budget: Budget, *, out=None, progress=None, seed: int = 0) -> list[dict]:
    """Run the ground-truth analogy (``budget.analogies`` questions per kind) and interpolation (``budget.paths``
    paths of 11 steps per kind) benchmarks of :mod:`opnet.apps`; rows get ``table`` ``"analogy"`` or
    ``"interpolation"``, and the ``row_fields`` of their method (:func:`application_methods`; none for a method
    without them, nor for the ground truth's rows). With ``out``, also writes ``interpolation_<kind>.png`` and
    ``analogy_<kind>.png`` there.
    """
    from . import apps

    quads = [apps.analogy_quadruples(coll, kind, budget.analogies, seed=seed) for kind in apps.ANALOGY_KINDS]
    paths = [apps.interpolation_paths(coll, kind, budget.paths, seed=seed) for kind in apps.PATH_KINDS]
    ana = apps.analogy_benchmark(coll, methods, quads, progress=progress)  # a row per (method, kind)
    itp = apps.interpolation_benchmark(coll, methods, paths, progress=progress)  # per (kind, truth or method)
    owners = [m for m in methods for _ in quads], [m for _ in paths for m in (None, *methods)]
    rows = [dict(r, table="analogy", **getattr(m, "row_fields", {})) for r, m in zip(ana, owners[0], strict=True)]
    rows += [
        dict(r, table="interpolation", **getattr(m, "row_fields", {})) for r, m in zip(itp, owners[1], strict=True)
    ]
    if out is not None:
        application_figures(Path(out), coll, methods, quads, paths)
    return [dict(r, preset=coll.meta.get("preset")) for r in rows]


def refinement_curves(coll, idx, inits: dict, steps: int, snapshot_steps=(), *, device="cpu") -> tuple[dict, dict]:
    """Run :func:`opnet.reconstruct` (settings :data:`REFINE`) on shapes ``idx`` from each start in ``inits``
    (name → ``"base"`` or vertices ``(len(idx), n, 3)``), recording after every step the mean relative operator
    mismatch and the mean ``d_R``. Returns ``curves`` (name → ``step``, ``mismatch``, ``d_R`` lists, for
    :func:`opnet.plotting.plot_refinement_curves`) and ``snapshots`` (name → step → vertices of the first shape).

    ``opnet.experiments.figures.refinement_curves`` with the reproduction's :data:`REFINE`.
    """
    return _figures.refinement_curves(coll, idx, inits, steps, snapshot_steps, device=device, **REFINE)
