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

import shutil
import time
import warnings
from dataclasses import asdict
from pathlib import Path

import numpy as np

from . import __version__
from ._files import writer_lock
from .apps import PATH_KINDS
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
    POINT_VARIANTS,
    REFINE_SETS,
    TRAINING_FIELDS,
    Budget,
    ablation_label,
    bodies_group,
    declare,
    select,
    spec,
)
from .experiments.provenance import (
    inputs_digest,
    measured_checkpoints,
    record,
    run_checkpoints,
    run_finished,
    stamp,
    superseded,
)
from .experiments.report import (
    ablation_table,
    merge_blockers,
    merge_results,
    read_results,
    results_markdown,
    row_identity,
    write_results,
)
from .experiments.runner import Workspace, run_entries
from .experiments.shipped import shipped_figure, shipped_figures, shipped_results
from .experiments.spec import RunSpec
from .experiments.steps import (
    analogy_kinds,
    application_methods,
    applications_rows,
    discretisation_indices,
    discretisation_rows,
    refinement_curves,
    seeded_applications_rows,
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
    "analogy_kinds",
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
    plan = declare(config.training, ablation_sets=sets, seeds=config.seeds, ablation_grid=config.ablation_grid)
    return select(plan, config.parts())


def reproduce(config: ReproduceConfig | str = "quick", out=None, **options) -> list[dict]:
    """Reproduce the paper's Table 1, the rows beside it and the ablation on a collection; returns the rows, as
    written in ``results.json`` (the per-shape errors to :data:`~opnet.experiments.report.SHAPE_DIGITS` digits).

    ``config``: a :class:`~opnet.experiments.config.ReproduceConfig`, or a preset's name with the config's fields
    as keywords (``reproduce("quick", "out", ablation=False, collection="animals")``); ``out``: the output folder
    (default :func:`default_out`), reused to resume; one call at a time per folder (another gets
    :class:`opnet.FolderInUseError` naming the holder's PID).
    """
    if isinstance(config, str):
        config = ReproduceConfig(preset=config, out=None if out is None else str(out), **options)
    elif options or out is not None:
        raise TypeError("give either a ReproduceConfig or a preset with keywords, not both.")
    out = Path(config.out) if config.out is not None else default_out(config.preset, config.collection)
    if out.exists() and not out.is_dir():
        raise ValueError(f"out={out} is a file; give a folder.")
    with writer_lock(out, "reproduction (opnet.reproduce)"):  # one call per folder: its rows are one call's
        return _reproduce(config, out)


def _reproduce(config: ReproduceConfig, out: Path) -> list[dict]:
    """:func:`reproduce`'s work, its folder held."""
    from tqdm.auto import tqdm

    from .devices import resolve_device

    budget, profile, progress = config.training, config.profile, config.progress
    (out / "runs").mkdir(parents=True, exist_ok=True)
    device, t_start = resolve_device(config.device), time.perf_counter()
    plan = plan_for(config)
    coll, new = _collection(config, plan)
    context = _context(config, coll, device, plan)
    earlier, source = _earlier(config, out, context)  # kept where not measured again

    row_stamp = {k: context[k] for k in ("commit", "date", "machine", "preset")}  # each row's provenance
    before = earlier[0] if earlier is not None else []
    dropped = {}  # row identity → table, of the earlier rows this call's trainings superseded

    def save(rows):  # results.json/md: this call's rows, and an earlier call's that it did not measure again
        kept = None
        if earlier is not None:  # a run this call trained again (or under another id), to another checkpoint
            here, mine = run_checkpoints(out / "runs", finished=True), measured_checkpoints(rows)
            gone = [superseded(r, here) or superseded(r, mine, by_name=True) for r in earlier[0]]
            dropped.update({row_identity(r): r.get("table") for r, g in zip(earlier[0], gone) if g})
            kept = ([r for r, g in zip(earlier[0], gone) if not g], earlier[1])
        merged, merged_context = merge_results(kept, rows, context)
        return write_results(out, merged, merged_context, time.perf_counter() - t_start)  # the rows as written

    bar = tqdm(total=len(plan), desc="reproduce", unit="step", disable=progress is False)
    extra_channels = [ip.name for ip in new]
    where = dict(device=device, data_root=config.data_root, progress=progress, bar=bar, extra_channels=extra_channels)
    ws = Workspace(coll, profile, out / "runs", budget, **where)
    first = [e for e in plan.entries if e.table != "ablation"]  # then the steps, then the ablation
    ablation = [e for e in plan.entries if e.table == "ablation"]
    # dispatched in the order measured: a digest two entries share trains in the first one's folder, where it is loaded
    trained = _SideBySide(config, ws, first + ablation, _scratch(out)) if config.jobs > 1 else None
    figures = out / "figures" if config.figures else None
    try:
        kept = dict(context=row_stamp, earlier=before)
        rows = _run_plan(config, plan.steps, (first, ablation), ws, save, figures, kept, trained)
    finally:
        if trained is not None:
            trained.close()
    bar.close()
    _lost(rows, dropped, source, {s.key for s in plan.steps}, figures)
    return rows


def _earlier(config: ReproduceConfig, out: Path, context: dict):
    """The rows of an earlier call that this call keeps where it does not measure them again, and where they come
    from: ``out/results.json``, or, with ``config.from_shipped`` when there is none, the shipped results (refused when
    their :func:`~opnet.experiments.report.merge_blockers` are not ``[]``; their figures are copied into
    ``out/figures``). Rows that record another checkpoint of a finished run in ``out/runs`` are dropped, with a
    warning. ``((rows, context), source)``, or ``(None, None)``.
    """
    if (out / "results.json").is_file():
        earlier, source = read_results(out), str(out / "results.json")
    elif config.from_shipped:
        rows, shipped = shipped_results(config.preset, config.collection)
        source = f"the shipped {config.preset} results"
        earlier = (rows, dict(shipped, carried_from=source))  # said of its rows' call in this folder's context
        blockers = merge_blockers(earlier[1], context)
        if blockers:
            raise ValueError(
                f"--from-shipped: {source} were measured with another {', '.join(blockers)} than this call's, so "
                "they cannot stand beside its rows; run with the shipped settings (the preset's own seeds and "
                "budget), or without --from-shipped."
            )
        if config.figures:  # those of the parts this call leaves out are then shipped again with its own
            (out / "figures").mkdir(exist_ok=True)
            for name in shipped_figures(config.preset, config.collection):
                if not (out / "figures" / f"{name}.png").is_file():
                    shutil.copyfile(
                        shipped_figure(name, config.preset, config.collection), out / "figures" / f"{name}.png"
                    )
    else:
        return None, None
    checkpoints = run_checkpoints(out / "runs", finished=True)  # a run not here leaves its rows standing
    fresh = [r for r in earlier[0] if not superseded(r, checkpoints)]
    if len(fresh) < len(earlier[0]):
        warnings.warn(
            f"{source}: {len(earlier[0]) - len(fresh)} of its {len(earlier[0])} rows measured trainings that are not "
            "their runs' current ones (or record none); they are dropped and measured again where this call's plan "
            "has them.",
            stacklevel=3,
        )
    return (fresh, earlier[1]), source


#: The figures a step of the plan draws from its networks, by the table of its rows (file-name patterns).
_STEP_FIGURES = {
    "discretisation": ("discretisation", ("discretisation.png",)),
    "analogy": ("applications", ("analogy_*.png",)),
    "interpolation": ("applications", ("interpolation_*.png",)),
}


def _lost(rows: list[dict], dropped: dict, source, steps: set, figures) -> None:
    """Warn of the rows kept from ``source`` that this call's trainings superseded (``dropped``: identity → table)
    and did not measure again (not in the final ``rows``), naming their tables, and delete the figures a step left out
    of this call (not in ``steps``) drew of them: a call with those parts measures and draws them again.
    """
    final = {row_identity(r) for r in rows}
    gone = [table for identity, table in dropped.items() if identity not in final]
    if not gone:
        return
    lost = sorted(set(map(str, gone)))
    stale = [table for table in lost if table in _STEP_FIGURES and _STEP_FIGURES[table][0] not in steps]
    if figures is not None:
        for table in stale:
            for pattern in _STEP_FIGURES[table][1]:
                for path in figures.glob(pattern):
                    path.unlink()
    warnings.warn(
        f"{len(gone)} rows kept from {source} ({', '.join(lost)}) measured trainings that this call trained again to "
        "other checkpoints, and this call does not measure them: they are dropped"
        + (f", with the figures of their {', '.join(stale)} rows" if stale and figures is not None else "")
        + "; a call with their parts measures them again.",
        stacklevel=3,
    )


def _run_plan(config, steps, entries, ws: Workspace, save, figures, kept: dict, trained) -> list[dict]:
    """The plan's entries but the ablation's, its ``steps``, then the ablation's entries (``entries``: those two
    lists), each written (``save``) once measured; ``kept``: each row's provenance ``context`` and the ``earlier``
    rows kept where measured on the same inputs; ``trained``: the :class:`_SideBySide` trainings an entry waits for
    (``None``: it trains them here).
    """
    first, ablation = entries
    extra = dict(preset=config.preset)
    each = config.seeds > 1  # rows then hold their per-shape errors: the claims compare them
    ready = None if trained is None else trained.wait
    options = dict(extra=extra, per_shape=each, ready=ready, **kept)
    rows, done = run_entries(first, ws, saved=save, **options)
    if figures is not None:
        _figures(figures, ws, done, config.refine)
    for step in steps:
        rows += _step(step.key, ws, done, figures, extra, refine=config.refine, **kept)
        ws.bar.update(1)
        save(rows)
    more, _ = run_entries(ablation, ws, done=done, saved=lambda r: save(rows + r), **options)
    rows = save(rows + more)
    if figures is not None:
        _row_figures(figures, rows, config)
    return rows


def _collection(config: ReproduceConfig, plan):
    """The config's collection with every channel the plan's networks read (the ablation's sets of one's own computed
    once, cached beside it), and those added channels' inner products.
    """
    coll = config.profile.load(config.preset, config.data_root, config.progress)
    asked = {(c if isinstance(c, str) else c.name): c for e in plan.entries for s in e.runs for c in s.channels}
    new = [get_inner_product(c) for name, c in asked.items() if name not in coll.channels]
    return (coll.with_channels([*coll.channels, *new]) if new else coll), new


def _scratch(out: Path) -> Path:
    """``out/.joblib``, emptied: where joblib memory-maps the arrays it hands the side-by-side trainings. On disk, not
    in ``/dev/shm`` (joblib's default): a call stopped by SIGKILL cannot delete its maps, and in shared memory they
    would hold RAM until the machine restarts (a few GB per stopped `default` reproduction). The folder's writer
    lock makes this call its only user, so whatever an earlier call left there is deleted.
    """
    scratch = out / ".joblib"
    shutil.rmtree(scratch, ignore_errors=True)
    scratch.mkdir(parents=True)
    return scratch


class _SideBySide:
    """The unfinished trainings of ``entries`` (:meth:`Workspace.trainings`, in the plan's order) in ``config.jobs``
    processes, each with an equal share of the cores, into ``ws``'s runs folder; :meth:`wait` returns once an entry's
    own trainings are finished, so that the plan evaluates (and writes) each entry while later ones still train, and
    an interruption after hours keeps every row measured so far. joblib hands each process its collection (its
    arrays memory-mapped in ``scratch``, :func:`_scratch`, not copied); an interrupted run resumes from its last epoch.
    """

    def __init__(self, config: ReproduceConfig, ws: Workspace, entries, scratch: Path):
        from tqdm.auto import tqdm

        from ._extras import require
        from ._parallel import usable_cores

        joblib = require("joblib", "reproduce --jobs")
        self.pending, self.needs, declared = {}, {}, {}  # needs: each entry's trainings' digests
        for e in entries:  # as ws.trainings(entries), each entry's digests computed once
            mine = ws.trainings([e])
            self.needs[e.key] = set(mine)
            for digest, training in mine.items():
                declared.setdefault(digest, training)  # the first entry that declares it: its folder
        for digest, (key, draws, one) in declared.items():  # pending: dispatched, not yet seen finished
            coll = ws.data(key, draws)
            if not run_finished(one.run_dir(ws.runs_root, coll), one.epochs):
                self.pending[digest] = (one, coll)
        threads = max(1, usable_cores() // config.jobs)  # a training's share, however many are left (its numbers keep)
        task = joblib.delayed(_train_one)
        # config.jobs processes even for one training left: n_jobs=1 would run it in this process (its threads, watch)
        parallel = joblib.Parallel(n_jobs=config.jobs, return_as="generator_unordered", temp_folder=str(scratch))
        self.bar = tqdm(
            total=len(self.pending),
            desc=f"training {config.jobs} side by side",
            unit="network",
            disable=config.progress is False or not self.pending,
        )
        todo = [task(d, s, c, str(ws.runs_root), str(ws.device), threads) for d, (s, c) in self.pending.items()]
        self._finishing = parallel(todo) if todo else (d for d in ())

    def wait(self, entry) -> None:
        """Block until every training ``entry`` declares is finished (at once for a baseline or a refinement)."""
        waiting = self.needs[entry.key] & set(self.pending)
        while waiting:
            digest = next(self._finishing)  # the next to finish, of any entry
            waiting.discard(digest)
            self.bar.set_postfix_str(self.pending.pop(digest)[0].run_name)
            self.bar.update(1)

    def close(self) -> None:
        """Stop the trainings not waited for (none once every entry has been waited for; after an error or an
        interruption, the rest, without joblib's warning that it cancelled them) and the bar.
        """
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self._finishing.close()
        self.bar.close()


def _train_one(digest: str, spec, collection, runs_root: str, device: str, threads: int) -> str:
    """One training of :class:`_SideBySide`, in its own process with ``threads`` threads; returns ``digest`` (its
    :func:`opnet.train.run_digest`) once finished.
    """
    import torch

    from ._parallel import exit_with_parent
    from .experiments.runner import train_run

    exit_with_parent()  # a killed reproduce leaves no training behind in its folder
    torch.set_num_threads(threads)
    train_run(spec, collection, runs_root, device=device, progress=False)
    return digest


def _context(config: ReproduceConfig, coll, device, plan) -> dict:
    """What ``results.json`` says a reproduction ran on: preset, data, budget, machine, date, version, the collection,
    its splits' sizes and the plan's entries.
    """
    return dict(
        stamp(device),  # the machine, date and commit every row's provenance records too
        preset=config.preset,
        data=config.collection,
        budget=asdict(config.training),
        opnet_version=__version__,
        collection=repr(coll),
        splits={s: int(np.sum(coll.split == s)) for s in ("train", "val", "test", "test_subjects")},
        eval_subset=int(len(coll.eval_subset)),
        plan=plan.keys(),
        seeds=config.seeds,
        ablation_grid=config.ablation_grid,
        training_budget=config.training_budget,
    )


def _step(key: str, ws: Workspace, done: dict, figures, extra: dict, *, refine: bool, context, earlier) -> list[dict]:
    """The rows of one step of the plan (:class:`~opnet.experiments.plan.Step`): ``discretisation`` or
    ``applications`` (with the refined algebra when ``refine``), each with its ``provenance`` (the runs it decodes
    with). An earlier call's rows of the step with the same ``inputs`` digest (the same checkpoints, data and budget)
    are kept instead of measured again; their figures are then not drawn again either.
    """
    if key == "discretisation":
        decoders = [o for o in done.values() if o.entry.other_meshes]
        runs = [r for o in decoders for r in (o.runs if o.entry.replicated else o.runs[:1])]  # every seed decodes
        fields = {o.entry.name: {"entry": o.entry.key, **o.entry.run_fields()} for o in decoders}
        settings = dict(fields=fields, shapes=ws.budget.discretisation_shapes, funcchar=refine)
        drawn = ["discretisation"]
    else:
        keys = ("int+ext", "ours", "pointnet", *(k for k in POINT_VARIANTS if k in done))
        seeds = max(len(done[k].runs) if done[k].entry.replicated else 1 for k in keys)
        per_seed = [{k: done[k].runs[i if done[k].entry.replicated else 0] for k in keys} for i in range(seeds)]
        runs = [r for one in per_seed for r in one.values()]
        settings = dict(refine=refine, budget=[ws.budget.analogies, ws.budget.paths, ws.budget.apps_refine_shapes])
        settings["refine_steps"] = ws.budget.refine_steps if refine else None
        drawn = [
            f"{t}_{kind}"
            for t, kinds in (("analogy", analogy_kinds(ws.coll)), ("interpolation", PATH_KINDS))
            for kind in kinds
        ]
    inputs = inputs_digest(
        step=key, checkpoints=[r.checkpoint for r in runs], data=ws.fingerprint(ws.coll), extra=extra, **settings
    )
    kept = [r for r in earlier if (r.get("provenance") or {}).get("inputs") == inputs]
    if kept and (figures is None or all((figures / f"{name}.png").is_file() for name in drawn)):
        return kept  # measured by an earlier call on these checkpoints and data, its figures there
    if key == "discretisation":
        labels = {o.entry.name: ws.data("labels") for o in decoders if o.entry.trained_on == "labels"}
        rows = discretisation_rows(
            ws.coll,
            {o.entry.name: list(o.runs) if o.entry.replicated else o.runs[0].net for o in decoders},
            ws.budget,
            fields=fields,
            comp=ws.data("comp"),
            data_root=ws.data_root,
            progress=ws.progress,
            out=figures,
            shown=[
                o.entry.name for o in decoders if o.entry.key in ("int+ext", "comp-int+ext") or o.entry.name in labels
            ],
            extra=extra,
            funcchar=refine,
            device=ws.device,
            labels=labels,
        )
    elif seeds > 1:  # each seed's networks on the same questions and paths, summarised with intervals
        options = dict(refine=refine, device=ws.device, out=figures, progress=ws.progress)
        rows = seeded_applications_rows(ws.coll, per_seed, ws.budget, **options)
    else:
        algebras = application_methods(ws.coll, per_seed[0], ws.budget, refine=refine, device=ws.device)
        rows = applications_rows(ws.coll, algebras, ws.budget, out=figures, progress=ws.progress)

    def measured(row) -> list:  # the trainings its own method decoded with, not the whole step's
        names = row.get("runs") or ([row["run"]] if row.get("run") else [])  # run names, as the specs give them
        mine = [r for r in runs if r.spec.run_name in names]
        return mine if mine or not names else list(runs)  # a run it names that the step lacks: all of them

    return [dict(r, provenance=record(measured(r), context, inputs)) for r in rows]


def _figures(figures: Path, ws: Workspace, done: dict, refine: bool) -> None:
    """The figures drawn from the networks: training curves, reconstructions, refinement."""
    single = [o for o in done.values() if len(o.runs) == 1 or o.entry.replicated]  # a replicated one: every seed
    trained = [o for o in single if not o.entry.draws and o.entry.trained_on in ("base", "comp")]
    histories = {o.entry.name: [r.history for r in o.runs] for o in trained}
    paper, nn = done["int+ext"].method, done["nn"].method
    table1_figures(figures.parent, ws.coll, paper, nn, histories)
    if refine:
        refinement_figures(figures.parent, ws.coll, paper, ws.budget.refine_steps, device=ws.device, **REFINE)


def _row_figures(figures: Path, rows: list[dict], config: ReproduceConfig) -> None:
    """The figures drawn from the rows (those of this call and those it kept): the ablation's heat map, the rows
    beside Table 1 (unseen bodies, other triangulations).
    """
    from ._extras import require

    parts, tables = config.parts(), {r.get("table") for r in rows}  # the rows kept from earlier calls too
    drawn = {"ablation": ablation_figure} if "ablation" in parts or "ablation" in tables else {}
    beside = {"maps", "bodies"} & set(parts) or "discretisation" in tables or any(r.get("bodies") for r in rows)
    drawn |= {"generalisation": generalisation_figure} if beside else {}
    plt = require("matplotlib.pyplot", "opnet.reproduce's figures") if drawn else None
    for name, draw in drawn.items():
        fig = draw(rows)
        fig.savefig(figures / f"{name}.png", dpi=120)
        plt.close(fig)


def run_path(out, collection, table: str, channels, depth: int = 1, variant: str = "paper", *, budget=None) -> Path:
    """The run directory :func:`reproduce` uses for one network of ``collection`` at its preset's budget (or
    ``budget``, a :class:`~opnet.experiments.plan.Budget`):
    ``out/runs/<table>-<channels>-d<depth>-<digest>`` (:meth:`opnet.experiments.RunSpec.run_dir` of
    :func:`~opnet.experiments.plan.spec`; the digest covers the budget, the data and the channels, so another budget
    or collection is another folder).

    ``table`` is ``"table1"``, ``"comp"`` or ``"ablation"``; ``channels`` any channels (a set of built-ins goes by its
    short name ``A+E+C``, ``Ext``...); ``variant="ours"`` adds ``-ours``; ``variant="pointnet"`` names the PointNet
    autoencoder's run, ``out/runs/<table>-pointnet-<digest>`` (``channels`` and ``depth`` are then ignored).
    """
    if out is None:
        raise TypeError("out must be the reproduction's folder (its runs/ hold the networks), not None.")
    preset = collection.meta.get("preset")
    if budget is None and preset not in BUDGETS:
        raise ValueError(
            f"the collection's preset is {preset!r}, which has no budget: pass budget= (e.g. BUDGETS['quick'])."
        )
    budget = BUDGETS[preset] if budget is None else budget
    return spec(table, budget, channels, depth, variant).run_dir(Path(out) / "runs", collection)


def notebook_out(preset: str, root=None) -> Path:
    """The reproduction folder the notebooks share at ``preset`` (its ``runs/`` hold their networks):
    ``<root>/reproduce-<preset>``, ``root`` by default :func:`opnet.data.default_root`. Each network's folder name
    carries a digest of its budget and data (:meth:`opnet.experiments.RunSpec.run_id`), so a release that changes a
    preset's budget trains new runs beside the old ones instead of resuming them.
    """
    from .data import default_root

    if preset not in BUDGETS:
        raise ValueError(f"unknown preset {preset!r}; use one of {list(BUDGETS)}.")
    return Path(default_root() if root is None else root) / f"reproduce-{preset}"
