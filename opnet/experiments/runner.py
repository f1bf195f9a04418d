"""The one runner: train (or load) each declared run in its folder, evaluate the networks into rows, and the
ablation over any channels (:func:`ablation`, :func:`opnet.ablation`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..evaluate import evaluate, nearest_neighbour_method, operatornet_method, pointnet_method
from ..inner_products import channel_names
from .spec import RunSpec

__all__ = [
    "Run",
    "Results",
    "train_run",
    "evaluate_runs",
    "ablation",
    "Outcome",
    "Workspace",
    "build_method",
    "run_entries",
    "evaluate_seeds",
    "entry_runs",
]


@dataclass(eq=False)
class Run:
    """A trained (or loaded) run: its spec, network, history, folder (``None`` in memory), ``info`` (``epochs``,
    ``train_seconds``, ``device``: fields of its rows), the SHA-256 of its ``best.pt`` (``None`` in memory) and its
    :func:`opnet.train.convergence` (a dict): what its rows' ``provenance`` and ``convergence`` record.
    """

    spec: RunSpec
    net: object
    history: list
    run_dir: Path | None
    info: dict = field(default_factory=dict)
    checkpoint: str | None = None
    convergence: dict | None = None

    @property
    def run_id(self) -> str | None:
        """The name of its folder (:meth:`RunSpec.run_id`), ``None`` in memory."""
        return None if self.run_dir is None else self.run_dir.name

    def method(self, collection, **fields):
        """The :class:`opnet.evaluate.Method` of this run's network on ``collection``, named by :attr:`RunSpec.label`,
        its rows carrying the spec's fields, the run's info and ``fields`` (e.g. ``table``).
        """
        info = {**self.spec.fields(), **self.info, **fields}
        if self.spec.reads_points:
            return pointnet_method(self.net, collection, self.spec.label, info=info)
        return operatornet_method(self.net, collection, self.spec.label, info=info)


class Results(list):
    """Rows (dicts with structured fields: ``method``, ``run``, ``channels``, ``depth``, ``split``, ``d_R`` ...),
    shown in a notebook as a Markdown table of ``d_R`` (×10⁻⁴). :meth:`pivot` lays them out as the paper's ablation.
    """

    def _rows(self, metric: str, split: str | None) -> dict:
        """``{channels label: {depth: row}}`` of the rows of one split that have ``metric``."""
        from ..inner_products import channel_label

        split = split or next((r["split"] for r in self), None)
        out: dict = {}
        for r in self:
            if r["split"] == split and r.get(metric) is not None:
                key = channel_label(r["channels"]) if r["channels"] else r["method"]
                if r.get("variant") not in (None, "paper"):  # runs that differ by more than channels and depth
                    key += f" ({r['variant']})"
                out.setdefault(key, {})[r.get("depth")] = r
        return out

    def pivot(self, metric: str = "d_R", split: str | None = None, scale: float = 1e4) -> dict:
        """``{channels label: {depth: value}}`` of ``metric`` (× ``scale``; over seeds, their mean) for the rows of
        one split (default: the first one present), one entry per network; baselines (no depth) under depth ``None``.
        """
        return {k: {d: r[metric] * scale for d, r in row.items()} for k, row in self._rows(metric, split).items()}

    def compare(self, a, b, *, depth: int = 1, metric: str = "d_R", split: str | None = None):
        """Does channel set ``a`` decode better than ``b`` at ``depth``? Their paired comparison on ``split`` (default
        the first one present): :func:`opnet.experiments.stats.compare` of the two networks' rows, with its interval
        over seeds and shapes and its verdict (``"a better"``, ``"b better"`` or ``"no difference shown"``).
        """
        from ..inner_products import split_channels
        from .stats import compare

        split = split or next((r["split"] for r in self), None)
        fields = [dict(channels=channel_names(split_channels(x)), depth=depth, baseline=None) for x in (a, b)]
        return compare(self, *fields, metric=metric, split=split)

    def markdown(self, metric: str = "d_R", split: str | None = None, scale: float = 1e4) -> str:
        """The :meth:`pivot` as a Markdown table: a row per channel set, a column per depth; ``mean ± half-width`` of
        the 95 % interval where the rows have one (over seeds and shapes).
        """
        table = self._rows(metric, split)
        depths = sorted({d for row in table.values() for d in row}, key=lambda d: (d is None, d or 0))
        head = ["channels", *[f"depth {d}" if d is not None else "baseline" for d in depths]]
        split = split or next((r["split"] for r in self), "")
        lines = [
            f"{metric} ×{_power_text(1 / scale)} on {split}" if scale != 1 else f"{metric} on {split}",
            "",
            "| " + " | ".join(head) + " |",
            "|" + "---|" * len(head),
        ]

        def cell(r) -> str:
            if r.get(f"{metric}_low") is None:
                return f"{scale * r[metric]:.3f}"
            return f"{scale * r[metric]:.3f} ± {scale * (r[f'{metric}_high'] - r[f'{metric}_low']) / 2:.2g}"

        for key, row in table.items():
            cells = [cell(row[d]) if d in row else "" for d in depths]
            lines.append("| " + " | ".join([key, *cells]) + " |")
        return "\n".join(lines)

    def _repr_markdown_(self) -> str:
        return self.markdown()


def train_run(spec, collection, run_root=None, *, device="auto", progress=None):
    """Train ``spec`` (a :class:`~opnet.experiments.spec.RunSpec`) on ``collection`` in
    ``run_root / spec.run_id(collection)`` (:func:`opnet.train.fit`: an interrupted run continues from its last epoch,
    a finished one is loaded), or in memory when ``run_root`` is ``None``; a :class:`Run`.
    """
    from ..train import checkpoint_sha256, convergence, fit

    run_dir = spec.run_dir(run_root, collection)
    net, history = fit(collection, device=device, run_dir=run_dir, progress=progress, **spec.fit_options())
    trained_on = str(next(net.parameters()).device)
    if run_dir is not None:  # a reused run may have been trained elsewhere
        trained_on = json.loads((run_dir / "config.json").read_text())["device"]
    info = dict(epochs=len(history), train_seconds=round(sum(e["seconds"] for e in history), 1), device=trained_on)
    checkpoint = None if run_dir is None else checkpoint_sha256(run_dir)
    return Run(spec, net, history, run_dir, info, checkpoint, convergence(history).as_dict())


def evaluate_runs(runs, collection, test_sets=("val",), *, extra: dict | None = None):
    """Rows (:class:`Results`) of every run's network on ``collection`` (:func:`opnet.evaluate.evaluate` on
    ``test_sets``).
    """
    return Results(evaluate(collection, [run.method(collection) for run in runs], test_sets, extra=extra))


def evaluate_seeds(collection, methods, test_sets, *, extra: dict | None = None) -> list[dict]:
    """One row per test set over ``methods``, one trained network per seed: each evaluated on the same shapes with
    its per-shape errors, then summarised (:func:`opnet.experiments.stats.summarize_seeds`).
    """
    from .stats import summarize_seeds

    each = [evaluate(collection, [m], test_sets, extra=extra, per_shape=True) for m in methods]
    return [summarize_seeds(list(split)) for split in zip(*each)]


def ablation(
    collection,
    channel_sets,
    depths=(1,),
    epochs: int = 50,
    *,
    seeds=1,
    run_root=None,
    test_sets=("val",),
    baselines: bool = True,
    device="auto",
    progress=None,
    **train_options,
):
    """The ablation of Appendix B over any channels: OperatorNet trained on each set of ``channel_sets`` at each of
    ``depths`` for ``epochs``, with each of ``seeds``, evaluated on ``test_sets`` (default ``val``, where experiments
    are chosen; the test sets belong to a final evaluation), beside the nearest-neighbour baseline on the same
    channels.

    Parameters
    ----------
    collection : a collection holding every channel asked for (add yours with
        :meth:`~opnet.data.storage.Collection.with_channels`).
    channel_sets : a list of channel sets (each a list of names or inner products, or a short name like ``"A+E"``).
    depths : encoder depths (1–4).
    epochs : training epochs of each network.
    seeds : how many trainings of each network (seeds 0, 1, ...), or the seeds themselves; its rows summarise them
        (:func:`opnet.experiments.stats.summarize_seeds`: the mean, the spread over seeds, a 95 % interval).
    run_root : where each run gets its folder (resumable; a finished run is loaded); ``None``: in memory.
    baselines : also the nearest-neighbour rows (``depth`` ``None``) of each channel set.
    train_options : other fields of :class:`~opnet.experiments.spec.RunSpec` (``batch_size``, ``lr``, ``hidden``,
        ``variant``).

    Returns
    -------
    opnet.experiments.runner.Results : one row per (network, test set), and per (baseline, test set), each with its
        per-shape errors; ``Results.markdown()`` pivots them, ``Results.compare`` answers "does this set help over
        that one?".
    """
    from tqdm.auto import tqdm

    if "seed" in train_options:
        raise TypeError("ablation trains every network with each of seeds=: give seeds=(s,) for one seed s.")
    seeds = tuple(range(seeds)) if isinstance(seeds, int) and not isinstance(seeds, bool) else tuple(seeds)
    if not seeds:
        raise ValueError("seeds must be a count >= 1 or a sequence of seeds, e.g. 3 or (0, 1, 2).")
    specs = [
        RunSpec(channels=channels, depth=depth, epochs=epochs, group="ablation", seeds=seeds, **train_options)
        for channels in channel_sets
        for depth in depths
    ]
    from .provenance import inputs_digest, record, stamp

    bar = tqdm(total=len(specs) * len(seeds), desc="ablation", unit="network", disable=progress is False)
    rows = Results()
    context = stamp(device, collection)
    for spec in specs:
        runs = []
        for replicate in spec.replicates():
            bar.set_postfix_str(f"{spec.label}, seed {replicate.seed}")
            runs.append(train_run(replicate, collection, run_root, device=device, progress=progress is True))
            bar.update(1)
        methods = [run.method(collection, seed=run.spec.seed) for run in runs]
        prov = record(runs, context, inputs_digest(checkpoints=[r.checkpoint for r in runs], test_sets=test_sets))
        convergence = [r.convergence for r in runs]
        rows += [
            dict(r, provenance=prov, convergence=convergence) for r in evaluate_seeds(collection, methods, test_sets)
        ]
    bar.close()
    if baselines:
        seen = []
        for spec in specs:
            if spec.channel_names not in seen:
                seen.append(spec.channel_names)
                info = dict(run=None, architecture=None, variant=None, channels=list(spec.channel_names), depth=None)
                nn = nearest_neighbour_method(collection, spec.channels, info=dict(info, baseline="nearest_neighbour"))
                inputs = inputs_digest(baseline="nearest_neighbour", channels=info["channels"], test_sets=test_sets)
                prov = record([], context, inputs)
                rows += [dict(r, provenance=prov) for r in evaluate(collection, [nn], test_sets, per_shape=True)]
    return rows


# -- the plan ------------------------------------------------------------------------------------------------------


@dataclass(eq=False)
class Outcome:
    """What one plan entry gave: the entry, its method, its trained runs (none for a baseline or a refinement) and
    the collection it was tested on.
    """

    entry: object
    method: object
    runs: list
    tested_on: object
    methods: list = field(default_factory=list)  # a replicated entry's: one per seed (``method`` is the first's)
    start: object = None  # a refinement's: the outcome of the entry it refines


class Workspace:
    """What the runner needs to run a plan's entries: the collection (and what is derived from it, built once when
    first asked for, :meth:`data`), its profile, the run folders' root, the budget, the device, the progress bar.
    """

    def __init__(
        self, coll, profile, runs_root, budget, *, device="cpu", data_root=None, progress=None, bar=None,
        extra_channels=(),
    ):  # fmt: skip
        self.coll, self.profile, self.runs_root, self.budget = coll, profile, Path(runs_root), budget
        self.device, self.data_root, self.progress, self.bar = device, data_root, progress, bar
        self.extra_channels = tuple(extra_channels)  # names of channels added for the ablation's own sets
        self._data: dict = {}
        self._fingerprints: dict = {}  # id of a collection -> (the collection, kept alive; its fingerprint)
        self._runs: dict = {}  # run digest -> the Run trained (or loaded) for it in this workspace

    def data(self, key: str, draws: dict | None = None):
        """The collection an entry trains or tests on (:data:`~opnet.experiments.plan.DATA`; ``draws``: the profile's
        collection drawn with other bodies or poses, whose held-out shapes are checked to be the same).
        """
        ident = (key, tuple(sorted((draws or {}).items())))
        if ident not in self._data:
            self._data[ident] = self._build(key, draws or {})
        return self._data[ident]

    def _build(self, key, draws):
        from ..data import half_mapped, labels_collection, mapped_collection, three_way_mapped
        from .baselines import FUNCCHAR
        from .plan import COMP_RESOLUTION, LABELS_RESOLUTION

        coll, root, progress = self.coll, self.data_root, self.progress
        if draws:  # the same collection (preset, resolution, seed), its training shapes drawn otherwise
            meta = coll.meta
            where = {k: meta[k] for k in ("resolution", "seed") if k in meta}
            more = self.profile.load(meta["preset"], root, progress, **where, **draws)
            held = coll.split != "train"
            if not (
                np.array_equal(more.split, coll.split) and np.array_equal(more.vertices[held], coll.vertices[held])
            ):
                raise ValueError(f"the collection with {draws} does not hold {coll!r}'s held-out shapes.")
            return more
        if key == "base":
            return coll
        if key == "comp":
            return mapped_collection(coll, COMP_RESOLUTION, "computed", root=root, progress=progress)
        if key == "half":
            return half_mapped(coll, self.data("comp"))
        if key == "three":
            return three_way_mapped(coll, self.data("comp"), "5k", root=root, progress=progress)
        if key == "offsets":
            return coll.with_channels([*dict.fromkeys([*coll.channels, *FUNCCHAR])], progress=False)
        if key == "labels":
            return labels_collection(coll, LABELS_RESOLUTION, root=root)
        raise ValueError(f"unknown data {key!r}.")

    def fingerprint(self, collection) -> str:
        """:func:`opnet.train.collection_fingerprint` of one of this workspace's collections, computed once: its shapes
        and the operators of its channels but its ``extra_channels`` (those added for the ablation's sets of one's
        own, which only their own networks read: asking for one does not make the other rows new).
        """
        from ..train import collection_fingerprint

        key = id(collection)
        if key not in self._fingerprints:
            channels = [c for c in collection.channels if c not in self.extra_channels]
            self._fingerprints[key] = (collection, collection_fingerprint(collection, channels))
        return self._fingerprints[key][1]

    def train(self, spec, collection):
        """Train (or load, when finished) ``spec`` on ``collection`` in this workspace's runs folder. Two specs with
        one :func:`opnet.train.run_digest` train the same weights (the ablation's A+E+C at depth 1 is Table 1's
        Int+Ext): the second gets the first's :class:`Run` (its network and folder, which its rows' ``provenance``
        then names) under its own spec, so that its rows carry its own name.
        """
        from ..train import run_digest

        digest = run_digest(collection, **spec.fit_options())
        if digest not in self._runs:
            if self.bar is not None:
                self.bar.set_postfix_str(spec.run_name)
            progress = self.progress is True
            self._runs[digest] = train_run(spec, collection, self.runs_root, device=self.device, progress=progress)
        return replace(self._runs[digest], spec=spec)

    def trainings(self, entries) -> dict:
        """Every training ``entries`` declare, one per :func:`opnet.train.run_digest` (the first spec that declares
        it): ``{digest: (data key, draws, spec)}``, building each collection they train on (:meth:`data`).
        """
        from ..train import run_digest

        out: dict = {}
        for entry in entries:
            if entry.baseline is not None or entry.refines is not None:
                continue
            collection = self.data(entry.trained_on, entry.draws)
            for spec in entry.spec.replicates() if entry.replicated else entry.runs:
                out.setdefault(run_digest(collection, **spec.fit_options()), (entry.trained_on, entry.draws, spec))
        return out


def _untrained(device) -> dict:
    """The fields of a row whose method trains nothing of its own: no epochs or training time, the device."""
    return dict(epochs=None, train_seconds=None, device=str(device))


def build_method(entry, ws: Workspace, done: dict) -> Outcome:
    """The method of ``entry`` (training its networks in ``ws``, or loading them when trained), its rows' fields
    given when it is built: ``table``, ``entry``, the run's or the baseline's fields, ``epochs``, ``train_seconds``,
    ``device``. ``done``: the outcomes of the entries before it (key → :class:`Outcome`), for a refinement.
    """
    from ..evaluate import ensemble_method, refined_method
    from .baselines import baseline_method, refine_options

    tested = ws.data(entry.tested_on)
    where = dict(table=entry.table, entry=entry.key)
    if entry.baseline is not None:
        method = baseline_method(entry.baseline, tested, ws.budget, ws.device)
        info = {**where, **entry.run_fields(), **_untrained(ws.device)}
        return Outcome(entry, replace(method, name=entry.name, info={**method.info, **info}), [], tested)
    if entry.refines is not None:
        if entry.refines not in done:
            raise ValueError(f"entry {entry.key!r} refines {entry.refines!r}, which has not run before it.")
        start = done[entry.refines]
        fields = {k: v for k, v in start.entry.run_fields().items() if k != "channels"}
        if start.entry.replicated:  # the first seed's output is refined (seconds per shape): its run, its seed
            fields |= dict(run=start.runs[0].spec.run_name, seeds=[start.runs[0].spec.seed])
        info = {**where, **fields, "refined": True, **_untrained(ws.device)}
        options = refine_options(ws.budget, ws.device)
        method = refined_method(start.method, tested, name=entry.name, info=info, **options)
        return Outcome(entry, method, [], tested, start=start)
    trained_on = ws.data(entry.trained_on, entry.draws)
    if entry.replicated:  # one run per seed, each its own method; their rows are summarised with intervals
        runs = [ws.train(s, trained_on) for s in entry.spec.replicates()]
        methods = [r.method(tested, **where, **entry.fields, seed=r.spec.seed) for r in runs]
        return Outcome(entry, methods[0], runs, tested, methods)
    runs = [ws.train(s, trained_on) for s in entry.runs]
    info = {**where, **entry.run_fields(), **runs[0].info}
    if len(runs) == 1:
        return Outcome(entry, runs[0].method(tested, **info), runs, tested)
    info["train_seconds"] = round(sum(r.info["train_seconds"] for r in runs), 1)
    method = ensemble_method([r.method(tested) for r in runs], entry.name, info=info)
    return Outcome(entry, method, runs, tested)


def entry_runs(outcome) -> list:
    """The trainings an outcome's rows measure: its runs, or for a refinement those of the entry it refines (a
    replicated one's first seed, the one refined); none for a baseline.
    """
    if outcome.runs:
        return list(outcome.runs)
    start = outcome.start
    if start is None:
        return []
    return list(start.runs[:1]) if start.entry.replicated else list(start.runs)


def run_entries(
    entries,
    ws: Workspace,
    *,
    extra: dict | None = None,
    done: dict | None = None,
    saved=None,
    per_shape: bool = False,
    context: dict | None = None,
    earlier=(),
    ready=None,
):
    """Build each entry's method (:func:`build_method`) and evaluate it on its test sets into rows; returns the rows
    and the outcomes (key → :class:`Outcome`). ``saved(rows)``: called after each entry with the rows so far (so an
    interruption loses one entry's work at most); ``ready(entry)``: called before an entry is built (to wait for its
    trainings in other processes). ``per_shape``: every row holds its per-shape errors (a row over
    seeds always does), so that a baseline can be compared with the networks (:func:`opnet.experiments.compare`).

    Each row gets a ``provenance`` (:func:`opnet.experiments.provenance.record`: its runs, their checkpoints' SHA-256,
    seeds, and ``context``'s commit, date, machine and preset) and, for a trained method, ``convergence`` (one
    :func:`opnet.train.convergence` per run). ``earlier``: rows of an earlier call; an entry whose earlier rows have
    the ``inputs`` digest it has now (the same checkpoints, data and evaluation settings) keeps them instead of being
    evaluated again.
    """
    from ..evaluate import test_sets_for
    from .provenance import inputs_digest, record

    done = {} if done is None else done
    context = context or {}
    rows = []
    for entry in entries:
        if ready is not None:
            ready(entry)
        outcome = build_method(entry, ws, done)
        done[entry.key] = outcome
        test_sets = list(entry.test_sets or test_sets_for(outcome.tested_on))
        runs = entry_runs(outcome)
        inputs = inputs_digest(
            entry=entry.key,
            fields=entry.run_fields() if entry.refines is None else entry.refines,
            table=entry.table,
            tested_on=entry.tested_on,
            test_sets=test_sets,
            checkpoints=[r.checkpoint for r in runs],
            data=ws.fingerprint(outcome.tested_on),
            budget=[ws.budget.refine_steps, ws.budget.refine_shapes],  # what it evaluates with (trained: checkpoints)
            per_shape=per_shape or bool(outcome.methods),
            extra=extra,
        )
        kept = [
            r for r in earlier if r.get("entry") == entry.key and (r.get("provenance") or {}).get("inputs") == inputs
        ]
        if sorted(r.get("split") for r in kept) == sorted(test_sets):
            new = kept  # measured by an earlier call on these very checkpoints and data
        else:
            if outcome.methods:  # one row per test set over the seeds (its run: all their runs, joined)
                new = evaluate_seeds(outcome.tested_on, outcome.methods, test_sets, extra=extra)
            else:
                new = evaluate(outcome.tested_on, [outcome.method], test_sets, extra=extra, per_shape=per_shape)
            convergence = [r.convergence for r in runs if r.convergence is not None] if outcome.runs else None
            prov = record(runs, context, inputs)
            new = [dict(r, provenance=prov, **({"convergence": convergence} if convergence else {})) for r in new]
        rows += new
        if ws.bar is not None:
            ws.bar.update(1)
        if saved is not None:
            saved(rows)
    return rows, done


def _power_text(factor: float) -> str:
    """``factor`` as the tables write their units: ``10⁻⁴`` for a power of ten, else ``%g`` (``0.5``)."""
    exponent = round(math.log10(factor)) if factor > 0 else None
    if exponent is None or not math.isclose(factor, 10.0**exponent, rel_tol=1e-9):
        return f"{factor:g}"
    return "10" + str(exponent).translate(str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹"))
