"""The pipeline behind ``python -m opnet reproduce``: a collection → the plan's entries → results.json/md, figures.

:func:`reproduce` loads the collection of a :class:`~opnet.experiments.config.ReproduceConfig` (its profile says what
applies to it, :class:`opnet.data.Profile`), selects the entries of the plan (:func:`opnet.experiments.plan.declare`,
:func:`~opnet.experiments.plan.select`: Table 1's networks and baselines, the computed-map rows, the rows trained
with more bodies, the refinements, the ablation), and hands them to the runner
(:func:`opnet.experiments.runner.run_entries`): each network is trained in its own run directory under ``OUT/runs/``
(a second call loads finished runs, an interrupted one continues from its last epoch), each method evaluated into
rows. It writes, after every entry (keeping the rows of an earlier call into ``OUT`` that this one does not measure
again, :func:`opnet.experiments.report.merge_results`):

- ``OUT/results.json``: ``{"format", "version", "context", "rows"}`` (:func:`read_results` reads it): the machine,
  data and budget, and the rows (``table``, ``entry``: the plan's key, ``method``: shown only, ``split``, ``d_R`` in
  m², ``d_V``, ``d_E`` and their medians, ``n_shapes``, ``epochs``, ``train_seconds``, ``preset``, ``device``; a
  network's run fields ``run``, ``architecture``, ``variant``, ``channels``, ``depth``, ``group``; a baseline's
  ``baseline``; a refinement's ``refined``);
- ``OUT/results.md``: Table 1 and the ablation laid out like the paper's, with its numbers beside ours (for a
  collection whose profile has them) and the targets' verdicts;
- ``OUT/figures/``: training curves, reconstructions coloured by per-vertex error, refinement curves, the ablation's
  heat map, the other triangulations, the rows beside Table 1, the applications' strips and grids.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from . import __version__
from .experiments.baselines import FUNCCHAR, REFINE
from .experiments.config import ReproduceConfig
from .experiments.figures import (
    ablation_figure,
    discretisation_figure,
    generalisation_figure,
    refinement_figures,
    snapshot_steps,
    table1_figures,
)
from .experiments.plan import (
    ABLATION_DEPTHS,
    ABLATION_SETS,
    BUDGETS,
    MORE_BODIES,
    REFINE_SETS,
    TRAINING_FIELDS,
    Budget,
    ablation_label,
    bodies_group,
    declare,
    select,
    spec,
)
from .experiments.report import ablation_table, merge_results, read_results, results_markdown, write_results
from .experiments.runner import Workspace, run_entries
from .experiments.spec import RunSpec
from .experiments.steps import (
    application_methods,
    applications_rows,
    discretisation_indices,
    discretisation_rows,
    refinement_curves,
)
from .inner_products import get_inner_product

__all__ = [
    "reproduce",
    "ReproduceConfig",
    "plan_for",
    "default_out",
    "run_path",
    "notebook_out",
    "Budget",
    "BUDGETS",
    "TRAINING_FIELDS",
    "MORE_BODIES",
    "REFINE",
    "REFINE_SETS",
    "FUNCCHAR",
    "ABLATION_SETS",
    "ABLATION_DEPTHS",
    "declare",
    "spec",
    "bodies_group",
    "discretisation_rows",
    "discretisation_indices",
    "discretisation_figure",
    "generalisation_figure",
    "application_methods",
    "applications_rows",
    "refinement_curves",
    "snapshot_steps",
    "ablation_table",
    "results_markdown",
    "read_results",
]


def default_out(preset: str, collection: str = "humans") -> Path:
    """The folder :func:`reproduce` writes into when not given one: ``reproduce-<profile.folder(preset)>``
    (``reproduce-<preset>`` for the humans, ``reproduce-<collection>-<preset>`` otherwise).
    """
    return Path(f"reproduce-{ReproduceConfig(preset=preset, collection=collection).profile.folder(preset)}")


def plan_for(config: ReproduceConfig):
    """The plan :func:`reproduce` runs for ``config``: every declared entry (the ablation with
    ``config.ablation_channels`` beside the paper's sets; each network with ``config.seeds`` seeds) kept by the
    config's parts.
    """
    sets = dict(ABLATION_SETS)
    for text in config.ablation_channels:
        channels = RunSpec(channels=text).channels  # classes and "module:Class" imported: named by their name
        sets.setdefault(ablation_label(channels), channels)
    return select(declare(config.training, ablation_sets=sets, seeds=config.seeds), config.parts())


def _machine(device) -> str:
    import torch

    if device.type == "cuda":
        return f"{torch.cuda.get_device_name(device)} (CUDA), torch {torch.__version__}"
    return (
        f"CPU ({platform.machine()}, {os.cpu_count()} cores, {torch.get_num_threads()} torch threads), "
        f"torch {torch.__version__}"
    )


def reproduce(config: ReproduceConfig | str = "quick", out=None, **options) -> list[dict]:
    """Reproduce the paper's Table 1, the rows beside it and the ablation on a collection; returns the rows.

    ``config``: a :class:`~opnet.experiments.config.ReproduceConfig`, or a preset's name with the config's fields
    as keywords (``reproduce("quick", "out", ablation=False, collection="animals")``); ``out``: the output folder
    (default :func:`default_out`), reused to resume.
    """
    from tqdm.auto import tqdm

    from .devices import resolve_device

    if isinstance(config, str):
        config = ReproduceConfig(preset=config, out=None if out is None else str(out), **options)
    elif options or out is not None:
        raise TypeError("give either a ReproduceConfig or a preset with keywords, not both.")
    budget, profile, progress = config.training, config.profile, config.progress
    out = Path(config.out) if config.out is not None else default_out(config.preset, config.collection)
    if out.exists() and not out.is_dir():
        raise ValueError(f"out={out} is a file; give a folder.")
    (out / "runs").mkdir(parents=True, exist_ok=True)
    device, t_start = resolve_device(config.device), time.perf_counter()
    earlier = read_results(out) if (out / "results.json").is_file() else None  # kept where not measured again
    plan = plan_for(config)
    coll = profile.load(config.preset, config.data_root, progress)
    asked = {(c if isinstance(c, str) else c.name): c for e in plan.entries for s in e.runs for c in s.channels}
    new = [get_inner_product(c) for name, c in asked.items() if name not in coll.channels]  # the ablation's own
    coll = coll.with_channels([*coll.channels, *new]) if new else coll  # computed once, cached beside it
    context = _context(config, coll, device, plan)

    def save(rows):  # results.json/md: this call's rows, and an earlier call's that it did not measure again
        merged, merged_context = merge_results(earlier, rows, context)
        write_results(out, merged, merged_context, time.perf_counter() - t_start)
        return merged

    bar = tqdm(total=len(plan), desc="reproduce", unit="step", disable=progress is False)
    ws = Workspace(
        coll, profile, out / "runs", budget, device=device, data_root=config.data_root, progress=progress, bar=bar
    )
    figures = out / "figures" if config.figures else None
    extra = dict(preset=config.preset)
    first = [e for e in plan.entries if e.table != "ablation"]
    each = config.seeds > 1  # rows then hold their per-shape errors: the claims compare them
    rows, done = run_entries(first, ws, extra=extra, saved=save, per_shape=each)
    if figures is not None:
        _figures(figures, ws, done, config.refine)
    for step in plan.steps:
        rows += _step(step.key, ws, done, figures, extra, refine=config.refine)
        bar.update(1)
        save(rows)
    more, _ = run_entries(
        [e for e in plan.entries if e.table == "ablation"],
        ws,
        extra=extra,
        done=done,
        saved=lambda r: save(rows + r),
        per_shape=each,
    )
    rows = save(rows + more)
    if figures is not None:
        _row_figures(figures, rows, config)
    bar.close()
    return rows


def _context(config: ReproduceConfig, coll, device, plan) -> dict:
    """What ``results.json`` says a reproduction ran on: preset, data, budget, machine, date, version, the collection,
    its splits' sizes and the plan's entries.
    """
    return dict(
        preset=config.preset,
        data=config.collection,
        budget=asdict(config.training),
        machine=_machine(device),
        date=time.strftime("%Y-%m-%d"),
        opnet_version=__version__,
        collection=repr(coll),
        splits={s: int(np.sum(coll.split == s)) for s in ("train", "val", "test", "test_subjects")},
        eval_subset=int(len(coll.eval_subset)),
        plan=plan.keys(),
        seeds=config.seeds,
    )


def _step(key: str, ws: Workspace, done: dict, figures, extra: dict, *, refine: bool) -> list[dict]:
    """The rows of one step of the plan (:class:`~opnet.experiments.plan.Step`): ``discretisation`` or
    ``applications`` (with the refined algebra when ``refine``).
    """
    if key == "discretisation":
        decoders = [o for o in done.values() if o.entry.other_meshes]
        return discretisation_rows(
            ws.coll,
            {o.entry.name: o.runs[0].net for o in decoders},
            ws.budget,
            fields={o.entry.name: {"entry": o.entry.key, **o.entry.run_fields(), **_first_seed(o)} for o in decoders},
            comp=ws.data("comp"),
            data_root=ws.data_root,
            progress=ws.progress,
            out=figures,
            shown=[o.entry.name for o in decoders if o.entry.key in ("int+ext", "comp-int+ext")],
            extra=extra,
        )
    runs = {k: done[k].runs[0] for k in ("int+ext", "ours", "pointnet")}
    algebras = application_methods(ws.coll, runs, ws.budget, refine=refine, device=ws.device)
    return applications_rows(ws.coll, algebras, ws.budget, out=figures, progress=ws.progress)


def _first_seed(outcome) -> dict:
    """The run fields of a replicated entry's first seed, which the steps decode with (none for one run)."""
    if not outcome.entry.replicated:
        return {}
    return dict(run=outcome.runs[0].spec.run_name, seeds=[outcome.runs[0].spec.seed])


def _figures(figures: Path, ws: Workspace, done: dict, refine: bool) -> None:
    """The figures drawn from the networks: training curves, reconstructions, refinement."""
    single = [o for o in done.values() if len(o.runs) == 1 or o.entry.replicated]  # a replicated one: its first seed
    trained = [o for o in single if not o.entry.draws and o.entry.trained_on in ("base", "comp")]
    histories = {o.entry.name: o.runs[0].history for o in trained}
    paper, nn = done["int+ext"].method, done["nn"].method
    table1_figures(figures.parent, ws.coll, paper, nn, histories)
    if refine:
        refinement_figures(figures.parent, ws.coll, paper, ws.budget.refine_steps, device=ws.device, **REFINE)


def _row_figures(figures: Path, rows: list[dict], config: ReproduceConfig) -> None:
    """The figures drawn from the rows: the ablation's heat map, the rows beside Table 1."""
    from ._extras import require

    parts = config.parts()
    drawn = {"ablation": ablation_figure} if "ablation" in parts else {}
    drawn |= {"generalisation": generalisation_figure} if {"maps", "bodies"} & set(parts) else {}
    plt = require("matplotlib.pyplot", "opnet.reproduce's figures") if drawn else None
    for name, draw in drawn.items():
        fig = draw(rows)
        fig.savefig(figures / f"{name}.png", dpi=120)
        plt.close(fig)


def run_path(out, table: str, channels, depth: int = 1, variant: str = "paper") -> Path:
    """The run directory :func:`reproduce` uses for one network: ``out/runs/<table>-<channels>-d<depth>``
    (:attr:`opnet.experiments.RunSpec.run_name` of :func:`~opnet.experiments.plan.spec`).

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
    (:data:`~opnet.experiments.plan.TRAINING_FIELDS`). A release that changes a preset's training budget trains its
    networks in a new folder, beside those of the old budget (a run directory refuses to resume a run of other settings:
    :class:`opnet.train.CheckpointError`); the old folder can be deleted.
    """
    from .data import default_root

    if preset not in BUDGETS:
        raise ValueError(f"unknown preset {preset!r}; use one of {list(BUDGETS)}.")
    fields = {name: getattr(BUDGETS[preset], name) for name in TRAINING_FIELDS}
    digest = hashlib.sha256(json.dumps(fields, sort_keys=True).encode()).hexdigest()[:8]
    return Path(default_root() if root is None else root) / f"reproduce-{preset}-{digest}"
