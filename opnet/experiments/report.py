"""The reproduction's report: rows (and their context) → ``results.md`` text, the targets' verdicts, the ablation's
table; :func:`write_results` writes ``results.json`` and ``results.md``.

Rows are found by their structured fields, never by their display name (``method``, shown as it is):

- runs (:meth:`opnet.experiments.RunSpec.fields`): ``run``, ``architecture``, ``variant``, ``channels`` (names; a
  comma-joined string in older files), ``depth``, and the spec's ``group`` (``"table1"``, ``"comp"``: trained
  through computed maps, ``"ablation"``);
- baselines: ``baseline`` (``"nearest_neighbour"``, ``"base_shape"``, ``"geometric"``, ``"funcchar"``,
  ``"funcchar_int"``, ``"sfl"``);
- a network's output refined by :func:`opnet.reconstruct`: its run's fields (not its ``channels``: those of the
  refinement) and ``refined`` ``True``;
- the tables: ``table`` (``"table1"``, ``"ablation"``, ``"discretisation"``, ``"analogy"``, ``"interpolation"``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from .._files import atomic_write
from ..data.profiles import profile_of
from ..evaluate import SPECIES_SETS
from .claims import claims_markdown
from .paper import PAPER_ABLATION, PAPER_ABLATION_DEPTHS, PAPER_ABLATION_SETS, PAPER_TABLE1
from .plan import BUDGETS, PAPER_ROWS, SUBSET_ENTRIES, ablation_label, declare
from .rows import matches, number_text, row_channels
from .targets import judge, targets_of

__all__ = [
    "MAPPED_GROUPS",
    "write_results",
    "merge_results",
    "merge_blockers",
    "row_identity",
    "results_markdown",
    "results_sections",
    "SECTION_TITLES",
    "context_markdown",
    "table1_markdown",
    "headline_markdown",
    "provenance_text",
    "seed_spread_markdown",
    "SHAPE_DIGITS",
    "value_text",
    "ablation_markdown",
    "discretisation_markdown",
    "read_results",
    "RESULTS_FORMAT",
    "RESULTS_VERSION",
    "applications_markdown",
    "provenance_markdown",
    "targets",
    "ablation_table",
    "ablation_columns",
    "row_channels",
    "row_key",
    "upgrade_rows",
    "matches",
    "paper_table1",
    "PAPER_TABLE1_ROWS",
]

_SPLIT_NAMES = {
    "eval_subset": "furthest-point subset",
    "test": "test",
    "test_subjects": "unseen subjects",
    "unseen_species": "unseen species",
}


def _profile(context: dict | None):
    """The profile of the collection a reproduction ran on (:func:`opnet.data.profiles.profile_of`; files written
    before ``context["data"]`` existed are the humans').
    """
    return profile_of((context or {}).get("data"))


#: The rows standing for each row of the paper's Table 1 (:data:`~opnet.experiments.paper.PAPER_TABLE1`): the fields
#: they have (:func:`matches`), from the plan's entries (:data:`opnet.experiments.plan.PAPER_ROWS`).
PAPER_TABLE1_ROWS = PAPER_ROWS
#: The groups of the networks tested on other data than the collection itself: on operators through computed maps
#: (the plan's entries tested on ``comp``: Table 1's "Comp" rows and those beside them; the README's headline leaves
#: them out, as the paper's does) or on labels of another mesh (``labels``: measured on other vertices).
MAPPED_GROUPS = tuple(
    dict.fromkeys(
        e.spec.group for e in declare(BUDGETS["quick"]).entries if e.runs and e.tested_on in ("comp", "labels")
    )
)
_PAPER = PAPER_TABLE1_ROWS["OperatorNet (Int+Ext)"]  # the paper's network: Table 1's reference
_OURS = dict(_PAPER, variant="ours")  # this project's variant, on the same input
_NN = PAPER_TABLE1_ROWS["Nearest neighbour (Int+Ext)"]
#: The paper's ordering of its three networks' d_R on ``test``: Int+Ext < Ext < Int.
_ORDER = ("OperatorNet (Int+Ext)", "OperatorNet (Ext)", "OperatorNet (Int)")


def _legacy_fields() -> dict:
    """Method name → structured fields, for the rows of a ``results.json`` written before rows had them.

    Older reproductions named each row by its display name alone, the names of the plan's Table 1 entries; an exact
    lookup by name (never a parse) gives those rows the fields of the runs and baselines they stand for.
    """
    entries = [e for e in declare(BUDGETS["quick"]).entries if e.table == "table1" and e.refines is None]
    fields = {e.name: e.run_fields() for e in entries if e.runs}
    no_channels = {k: v for k, v in fields["OperatorNet (Int+Ext)"].items() if k != "channels"}
    fields |= {f"{name} + refinement": dict(fields[name], refined=True) for name in list(fields)}
    fields |= {e.name: dict(baseline=e.baseline) for e in entries if e.baseline is not None}
    fields |= {  # the applications' methods (their rows carry ``scheme``)
        "OperatorNet (mult.)": no_channels,
        "OperatorNet (linear)": no_channels,
        "OperatorNet (mult.) + refinement": dict(no_channels, refined=True),
        "OperatorNet ours (mult.)": {k: v for k, v in fields["OperatorNet ours (Int+Ext)"].items() if k != "channels"},
    }
    return fields | {"Nearest neighbour": dict(baseline="nearest_neighbour")}


def upgrade_rows(rows: list[dict]) -> list[dict]:
    """``rows`` with the structured fields filled in where an older ``results.json`` lacks them.

    A row without ``run`` and ``baseline`` (written before rows had them) gets the fields of the method it is named
    for (an exact lookup in the fixed list of names older reproductions wrote); rows that have them, and names
    that are not in the list, are returned as they are (the latter still tell themselves apart by :func:`row_key`).
    A row whose ``seeds`` is a number (an ensemble of that many seeds, as files of before the field ``ensemble``
    wrote) gets it as ``ensemble``: ``seeds`` lists the seeds of a row over separate trainings.
    """
    legacy = _legacy_fields()
    rows = [{**legacy.get(r.get("method"), {}), **r} if "run" not in r and "baseline" not in r else r for r in rows]
    return [_ensemble_field(r) if isinstance(r.get("seeds"), int) else r for r in rows]


def _ensemble_field(row: dict) -> dict:
    out = {k: v for k, v in row.items() if k != "seeds"}
    out["ensemble"] = row["seeds"]
    return out


def row_key(row: dict) -> tuple:
    """What tells the methods of one table apart: ``(run, baseline, refined)``; its rows share it across splits.

    A row with neither ``run`` nor ``baseline`` (an older file's, not in :func:`upgrade_rows`' list) is told apart by
    its ``method``, the only identity it has.
    """
    legacy = row.get("method") if row.get("run") is None and row.get("baseline") is None else None
    return row.get("run"), row.get("baseline"), bool(row.get("refined")), legacy


def paper_table1(row: dict) -> tuple | None:
    """The paper's Table 1 numbers (d_R ×10⁻⁴, d_V, d_E) of the row it stands for (:data:`PAPER_TABLE1_ROWS`), or
    ``None``.
    """
    name = next((name for name, fields in PAPER_TABLE1_ROWS.items() if matches(row, **fields)), None)
    return None if name is None else PAPER_TABLE1[name]


def _find(rows, split=None, **fields) -> dict | None:
    """The first of ``rows`` on ``split`` (any when ``None``) that :func:`matches` ``fields``."""
    return next((r for r in rows if (split is None or r["split"] == split) and matches(r, **fields)), None)


def ablation_columns(rows) -> list[str]:
    """The ablation's columns: the paper's seven sets (:data:`~opnet.experiments.paper.PAPER_ABLATION_SETS`, in its
    order), then every other set the rows hold (channels of one's own), in the order they come.
    """
    extra = [ablation_label(row_channels(r)) for r in rows if r.get("table") == "ablation"]
    return list(dict.fromkeys([*PAPER_ABLATION_SETS, *extra]))


def ablation_table(rows, value: str = "mean") -> np.ndarray:
    """The ablation's d_R ×10⁻⁴ on ``test`` as a ``(depths, sets)`` array (NaN where not trained yet): rows
    ``PAPER_ABLATION_DEPTHS``, columns :func:`~opnet.experiments.report.ablation_columns` (the paper's grid, then any
    other set). ``value="half_width"``: the half-width of each cell's 95 % interval instead (NaN where its row has
    none: one training).
    """
    if value not in ("mean", "half_width"):
        raise ValueError(f"value must be 'mean' or 'half_width', got {value!r}.")
    columns = ablation_columns(rows)
    table = np.full((len(PAPER_ABLATION_DEPTHS), len(columns)), np.nan)
    for r in rows:
        if r.get("table") == "ablation" and r.get("depth") in PAPER_ABLATION_DEPTHS:
            column = columns.index(ablation_label(row_channels(r)))
            if value == "mean":
                cell = r["d_R"]
            elif r.get("d_R_low") is not None:
                cell = (r["d_R_high"] - r["d_R_low"]) / 2
            else:
                continue
            table[PAPER_ABLATION_DEPTHS.index(r["depth"]), column] = 1e4 * cell
    return table


#: How the tables say what a row over seeds prints.
_SEEDED = "a network trained with several seeds: mean ± half-width of the 95 % interval"


def value_text(row: dict, metric: str, scale: float = 1.0) -> str:
    """A row's ``metric`` (``"d_R"``, ``"d_V"``, ``"d_E"``...) times ``scale`` as the tables print it, three
    significant digits: ``mean ± half-width`` of its 95 % interval where it has one (a row over seeds,
    :func:`opnet.experiments.stats.summarize_seeds`), else the value; ``"–"`` where it is missing or not finite.
    """
    low, high = row.get(f"{metric}_low"), row.get(f"{metric}_high")
    if low is None or high is None:
        return number_text(row.get(metric), scale)
    return f"{number_text(row[metric], scale)} ± {number_text((high - low) / 2, scale, 2)}"


#: What ``results.json`` holds: ``{"format": RESULTS_FORMAT, "version": RESULTS_VERSION, "context", "rows"}``.
RESULTS_FORMAT, RESULTS_VERSION = "opnet.results", 2


#: Significant digits kept of the per-shape errors (``<metric>_shapes``) in ``results.json``: far below any
#: difference an interval can tell, and a ``default`` reproduction's file about half the size.
SHAPE_DIGITS = 7


def write_results(out: Path, rows: list[dict], context: dict, seconds: float) -> list[dict]:
    """Write ``out/results.json`` (the rows and ``context`` with ``wall_seconds`` = ``seconds``: all that
    :func:`results_markdown` needs) and ``out/results.md`` (that Markdown, of the rows as written), each atomically;
    returns the rows as written (what :func:`read_results` gives back).

    The per-shape errors (``<metric>_shapes``, per seed and shape: what the intervals and the claims' paired
    comparisons read) keep :data:`SHAPE_DIGITS` significant digits; they and the shapes' indices are written a list
    to a line; the rest as it is.
    """
    context = dict(context, wall_seconds=round(seconds, 1))
    rows = [{k: _rounded(v) if k.endswith("_shapes") else v for k, v in r.items()} for r in rows]
    data = dict(format=RESULTS_FORMAT, version=RESULTS_VERSION, context=context, rows=rows)
    atomic_write(out / "results.json", lambda f: f.write(_results_json(data).encode()))
    md = results_markdown(rows, context)
    atomic_write(out / "results.md", lambda f: f.write(md.encode()))
    return rows


def _rounded(value):
    """A (nested) list of numbers with :data:`SHAPE_DIGITS` significant digits; anything else as it is."""
    if isinstance(value, list):
        return [_rounded(v) for v in value]
    if isinstance(value, float) and math.isfinite(value):
        return float(f"{value:.{SHAPE_DIGITS}g}")
    return value


def _results_json(data: dict) -> str:
    """``data`` as JSON, indented, with each row's per-shape lists (``shapes``, ``<metric>_shapes``) on one line (a
    placeholder for each, then its compact text: thousands of numbers would otherwise take a line each).
    """
    compact, rows = {}, []
    for i, row in enumerate(data["rows"]):
        row = dict(row)
        for key in [k for k, v in row.items() if (k == "shapes" or k.endswith("_shapes")) and isinstance(v, list)]:
            mark = f"\x00{i}:{key}\x00"
            compact[json.dumps(mark)] = json.dumps(row[key], separators=(",", ":"))
            row[key] = mark
        rows.append(row)
    text = json.dumps(dict(data, rows=rows), indent=1)
    for mark, value in compact.items():
        text = text.replace(mark, value, 1)
    return text


def row_identity(row: dict) -> tuple:
    """What one measurement is: its ``table``, method (:func:`row_key`), ``split`` and, where the table has them, the
    encoding (``resolution``, ``maps``) and the application's ``kind``. A later measurement of the same identity
    replaces an earlier one (:func:`merge_results`).
    """
    return (
        row.get("table"),
        row_key(row),
        row.get("split"),
        row.get("resolution"),
        row.get("maps"),
        row.get("kind"),
        row.get("scheme"),
    )


def merge_results(earlier: tuple[list[dict], dict] | None, rows: list[dict], context: dict) -> tuple[list, dict]:
    """The rows and context that a call of ``reproduce`` writes into a folder that already holds results.

    ``earlier``: the folder's ``(rows, context)`` (:func:`read_results`), or ``None``. Its rows that this call did not
    measure again (their :func:`row_identity` is not among ``rows``) are kept, so that a call with fewer parts
    (``--no-ablation``, ``--no-maps`` ...) adds to the folder's results instead of losing them. The order is this
    call's (``rows``: the plan's entries, then its steps), each kept row behind the row before it in the old file (and
    behind the rows new to the file that this call has after that one): a row that a later call adds (``reproduce
    --points`` after the rest) stands beside its plan neighbours, not at the end, and a call that measures or keeps
    every row of a file that an older version wrote in the order measured puts it in order (until then, its rows not
    yet reached keep the file's order). ``context`` then lists under
    ``"earlier"`` the earlier call (its date, machine, wall time, the tables of the rows kept and, for rows carried
    from another folder, its context's ``carried_from``: where they came from) and the calls it
    listed itself: a chain of calls is listed whole, without telling which of them measured each kept row.
    Results of another preset, budget, collection or number of seeds are not merged (a warning says so): ``(rows,
    context)`` are returned as they are.
    """
    if not earlier or earlier[1] is None:
        return rows, context
    old_rows, old = earlier
    if merge_blockers(old, context):
        import warnings

        warnings.warn(
            f"results.json holds {len(old_rows)} rows of another preset, budget, collection or number of seeds; they "
            "are replaced, not merged (run into another folder to keep them).",
            stacklevel=2,
        )
        return rows, context
    merged, ids = list(rows), [row_identity(r) for r in rows]
    old_ids = [row_identity(r) for r in old_rows]
    measured, known, kept, before = set(ids), set(old_ids), [], None
    for i, r in zip(old_ids, old_rows):
        if i not in measured:  # kept, behind the row before it in the old file and this call's new rows after that
            at = ids.index(before) + 1 if before is not None else 0
            while at < len(ids) and ids[at] not in known:
                at += 1
            merged.insert(at, r)
            ids.insert(at, i)
            kept.append(r)
        before = i
    if not kept:
        return merged, context
    summary = {key: old[key] for key in ("date", "machine", "wall_seconds", "carried_from") if key in old}
    summary["tables"] = sorted({str(r.get("table")) for r in kept})
    return merged, dict(context, earlier=[*old.get("earlier", []), summary])


def merge_blockers(old: dict, context: dict) -> list[str]:
    """What keeps the rows of a call with ``context`` apart from those of an earlier call with ``old`` (two results
    files' contexts): the names of the settings that differ among ``preset``, ``budget``, ``splits``, ``shapes`` (the
    collection, its channels aside) and ``seeds`` (a file of before seeds were recorded: one each); ``[]`` when their
    rows merge (:func:`merge_results`).
    """
    differ = [key for key in ("preset", "budget", "splits") if old.get(key) != context.get(key)]
    differ += ["shapes"] if _shapes(old) != _shapes(context) else []
    return differ + (["seeds"] if old.get("seeds", 1) != context.get("seeds", 1) else [])


def _shapes(context: dict) -> str:
    """What a context says of the collection's shapes: its repr without the channels it held (a call that adds a
    channel, or a file written when the channels were called ``kinds``, holds the same shapes).
    """
    import re

    return re.sub(r", (kinds|channels)=\([^)]*\)", "", str(context.get("collection")))


def read_results(path) -> tuple[list[dict], dict | None]:
    """The rows of a ``results.json`` (:func:`~opnet.experiments.report.upgrade_rows`: an older file's get their
    structured fields) and its context (``None`` for a file of before version 2, which held the rows alone).

    Parameters
    ----------
    path : path
        ``results.json``, or the folder that holds it (a ``reproduce`` output folder).
    """
    path = Path(path)
    path = path / "results.json" if path.is_dir() else path
    data = json.loads(path.read_text())
    if isinstance(data, list):  # version 1: the rows
        return upgrade_rows(data), None
    if data.get("format") != RESULTS_FORMAT:
        raise ValueError(f"{path} is not a results.json that opnet's reproduce wrote (no format {RESULTS_FORMAT!r}).")
    return upgrade_rows(data["rows"]), data["context"]


def _encoder(depth: int) -> str:
    return f"Conv. {'×'.join(str(8 * 2**k) for k in range(depth))}"


def _epochs(n: int) -> str:
    """``"1 epoch"``, ``"60 epochs"``."""
    return f"{n} epoch{'' if n == 1 else 's'}"


def results_markdown(rows: list[dict], context: dict) -> str:
    """``results.md``: :func:`~opnet.experiments.report.results_sections` under their headings (the context's lines
    first).

    ``context``: ``preset``, ``machine``, ``collection``, ``eval_subset`` (its size), ``wall_seconds`` and ``budget``
    (the reproduction's budget as a dict: ``lr``, ``batch_size``, ``epochs``, ``ablation_epochs``...).
    """
    lines = [f"# OperatorNet reproduction · preset `{context['preset']}`", ""]
    for name, body in results_sections(rows, context).items():
        lines += ([] if name == "context" else ["", f"## {SECTION_TITLES[name]}", ""]) + body
    return "\n".join(lines) + "\n"


#: The headings of :func:`results_sections` in ``results.md``.
SECTION_TITLES = {
    "context": "",
    "claims": "Claims, judged on these rows",
    "table1": "Table 1: shape reconstruction",
    "targets": "Targets",
    "ablation": "Ablation (Appendix B): d_R ×10⁻⁴ on `test`",
    "discretisation": "Other triangulations: test shapes on 2k and 5k meshes",
    "applications": "Applications: analogy and interpolation against ground truth",
    "provenance": "Provenance: which training each row measured",
}


def results_sections(rows: list[dict], context: dict) -> dict[str, list[str]]:
    """The sections of ``results.md``, name → Markdown lines without their heading (:data:`SECTION_TITLES`): the
    ``context`` (machine, data, training), ``table1``, its ``targets``, the ``ablation``, the ``discretisation``
    rows and the ``applications``; a section without rows is left out. The docs' results page shows the shipped
    reproduction's sections one by one.
    """
    rows = upgrade_rows(rows)
    t1 = [r for r in rows if r.get("table") == "table1"]
    p = _profile(context)
    paper = p.paper_numbers
    sections = {"context": context_markdown(context), "claims": claims_markdown(rows) if paper else []}
    sections["table1"] = table1_markdown(rows, paper=paper)
    sections |= {"targets": targets(t1, paper=paper), "ablation": ablation_markdown(rows, context["budget"], paper)}
    other_meshes = discretisation_markdown(rows) if p.computed_maps else []  # its other triangulations
    sections |= {"discretisation": other_meshes, "applications": applications_markdown(rows, context)}
    sections["provenance"] = provenance_markdown(rows)
    return {name: lines for name, lines in sections.items() if lines}


def provenance_markdown(rows: list[dict]) -> list[str]:
    """Where the rows come from (lines): one line per method and its trainings (the rows' ``provenance``: run
    folders, the first 12 hex digits of each ``best.pt``'s SHA-256, seeds, commit, date, machine, preset), and
    whether each run's validation curve converged (:func:`opnet.train.convergence`); a sentence when no row records
    one (a file written before rows recorded their trainings).
    """
    rows = upgrade_rows(rows)
    if not any(isinstance(r.get("provenance"), dict) for r in rows):
        return [
            "These rows record no provenance: they were written before each row recorded the trainings it measured, "
            "so nothing here says which training of a run each row comes from."
        ]
    lines = [
        "Each row records the trainings it measured: the run folders (the run's name and a digest of its settings "
        "and data), each `best.pt`'s SHA-256 (first 12 hex digits; training is bit-deterministic on one machine, so "
        "it names the training), the seeds, and the commit, date, machine and preset of the call that measured it. "
        "Converged: the runs whose last 10 % of epochs are within 5 % of their best `val` d_R.",
        "",
        "| table | method | runs | best.pt SHA-256 | seeds | converged | commit | date | machine | preset |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    seen = set()
    for r in rows:
        p = r.get("provenance")
        if not isinstance(p, dict):
            lines.append(f"| {r.get('table')} | {r.get('method')} | (none recorded) | | | | | | | |")
            continue
        key = (r.get("table"), r.get("method"), p.get("inputs"))
        if key in seen:
            continue
        seen.add(key)
        conv = r.get("convergence") or []
        converged = f"{sum(bool(c['converged']) for c in conv)}/{len(conv)}" if conv else "–"
        commit = (p.get("commit") or "–")[:10] + ("-dirty" if str(p.get("commit", "")).endswith("-dirty") else "")
        runs = "<br>".join(run or "(in memory)" for run in p["runs"]) or "–"
        lines.append(
            f"| {r.get('table')} | {r.get('method')} | {runs} | "
            f"{'<br>'.join((c or '–')[:12] for c in p['checkpoints']) or '–'} | "
            f"{', '.join(map(str, p.get('seeds') or [])) or '–'} | {converged} | {commit} | {p.get('date')} | "
            f"{p.get('machine')} | {p.get('preset')} |"
        )
    return lines


def _earlier_lines(earlier: list[dict]) -> list[str]:
    """A line per earlier call (:func:`merge_results`' ``context["earlier"]``, oldest first), except that neighbouring
    calls that kept the same tables on the same date and machine (a run stopped and resumed) share one, with each
    call's wall time where it was recorded.
    """
    groups: list[tuple[tuple, list]] = []
    for e in earlier:
        key = (tuple(e["tables"]), e.get("date"), e.get("machine", "?"), e.get("carried_from"))
        if groups and groups[-1][0] == key:
            groups[-1][1].append(e.get("wall_seconds"))
        else:
            groups.append((key, [e.get("wall_seconds")]))
    lines = []
    for (tables, date, machine, carried), walls in groups:
        known = [f"{w:.0f}" for w in walls if w is not None]
        wall = f", wall time{'s' if len(known) > 1 else ''} {', '.join(known)} s" if known else ""
        if known and len(known) < len(walls):
            wall += f" ({len(walls) - len(known)} not recorded)"
        calls = "an earlier call" if len(walls) == 1 else f"{len(walls)} earlier calls"
        here = "in the same folder (finished runs reused)"
        where = f"carried here from {carried}, their trainings elsewhere" if carried else here
        lines.append(
            f"Rows kept from {calls} {where}: the tables {', '.join(tables)}, "
            f"measured{' on ' + date if date else ''} on {machine}{wall}."
        )
    return lines


def context_markdown(context: dict) -> list[str]:
    """What a reproduction ran on (lines): the machine, the wall time, the data and the training settings."""
    b = context["budget"]
    when = f" on {context['date']} (opnet {context['opnet_version']})" if "date" in context else ""
    return [
        f"Machine: {context['machine']}{when}. Wall time so far: {context['wall_seconds']:.0f} s "
        "(data, training, evaluation; finished runs are reused, so a resumed call counts only what it did).",
        "",
        *_earlier_lines(context.get("earlier", [])),
        *([""] if context.get("earlier") else []),
        f"Data: {context['collection']}; the furthest-point evaluation subset (the paper's 50 shapes: 5 per held-out "
        f"sequence) has {context['eval_subset']} shapes.",
        "",
        f"Training: Adam, {_schedule_text(b)}, batch {b['batch_size']}, {b['epochs']} epochs for Table 1's "
        f"OperatorNets ({b.get('pointnet_epochs', b['epochs'])} for the point-set autoencoders) and "
        f"{b['ablation_epochs']} for "
        "the ablation"
        + (" (fewer, to keep the 28-network grid affordable)" if b["ablation_epochs"] < b["epochs"] else "")
        + f"{_seeds_text(context)}; model selection on `val`. "
        + _profile(context).context,
    ]


def _schedule_text(budget: dict) -> str:
    """The learning rate of a budget in words: the paper's networks' schedule, and our variant's."""
    schedule = budget.get("schedule")
    if schedule in (None, "constant"):
        return (
            f"a constant lr {budget['lr']:g} for the paper's networks (one-cycle with peak {budget['lr']:g} for ours)"
        )
    return f"{schedule} schedule with peak lr {budget['lr']:g} for every network"


def _seeds_text(context: dict) -> str:
    seeds = context.get("seeds", 1)
    return f", each with {seeds} seeds (0–{seeds - 1})" if seeds > 1 else ", one seed each"


def table1_markdown(rows: list[dict], paper: bool = True) -> list[str]:
    """Table 1 (lines): every method's d_R, d_V and d_E per test set beside the paper's (``paper=False``: without
    the paper's columns, for data the paper gives no numbers on), its training time and its time per shape; empty
    without Table 1 rows.
    """
    t1 = [r for r in upgrade_rows(rows) if r.get("table") == "table1"]
    if not t1:
        return []
    lines = [
        f"d_R ×10⁻⁴ (m²), mean (median in brackets); {_SEEDED} over seeds and shapes.",
        "",
    ]
    keys = list(dict.fromkeys(row_key(r) for r in t1))
    splits = [s for s in SPECIES_SETS if any(r["split"] == s for r in t1)]
    head = (
        "| method | "
        + " | ".join(f"{_SPLIT_NAMES[s]}: d_R | d_V | d_E" for s in splits)
        + (" | paper d_R | d_V | d_E" if paper else "")
        + " | train s | s/shape |"
    )
    lines += [head, "|---" * (2 + 3 * len(splits) + (4 if paper else 1)) + "|"]
    subsampled = {}
    for key in keys:
        mine = [r for r in t1 if row_key(r) == key]
        name = mine[0]["method"]
        cells = []
        for s in splits:
            r = next((r for r in mine if r["split"] == s), None)
            cells += (
                [
                    value_text(r, "d_R", 1e4) + f" ({number_text(r['d_R_median'], 1e4)})",
                    value_text(r, "d_V"),
                    value_text(r, "d_E"),
                ]
                if r
                else ["–"] * 3
            )
            full = max((q["n_shapes"] for q in t1 if q["split"] == s), default=None)  # the whole test set
            if r and full is not None and r["n_shapes"] < full:
                where = f"{r['n_shapes']} of the {full} shapes of {_SPLIT_NAMES[s]}"
                subsampled.setdefault(key, (name, []))[1].append(where)
        published = (paper_table1(mine[0]) or (None, None, None)) if paper else ()
        secs = mine[0]["train_seconds"]
        per_shape = np.mean([r["seconds_per_shape"] for r in mine if "seconds_per_shape" in r] or [np.nan])
        lines.append(
            f"| {name} | "
            + " | ".join(cells)
            + "".join(" | –" if p is None else f" | {p:g}" for p in published)
            + f" | {'–' if secs is None else f'{secs:.0f}'} | {number_text(per_shape, digits=2)} |"
        )
    lines += [
        "",
        "s/shape: the method's wall time per reconstructed shape (decoding, search or optimisation; not training).",
    ]
    for name, where in subsampled.values():
        lines.append(
            f"{name}: evaluated on {', '.join(where)} (evenly spaced, to bound the optimisation's time; "
            "`Budget.refine_shapes`)."
        )
    return lines + seed_spread_markdown(t1)


def seed_spread_markdown(rows: list[dict], split: str = "test") -> list[str]:
    """How far one training is from another (lines): for each row over seeds on ``split``, each seed's mean d_R
    (×10⁻⁴, over the shapes) and their standard deviation; empty when no row has seeds. What the interval cannot
    show: a single training's number may be anywhere in this range.
    """
    seeded = [r for r in rows if r.get("split") == split and r.get("d_R_seeds")]
    if not seeded:
        return []
    lines = ["", f"Seed to seed, `{split}` d_R ×10⁻⁴ (each training's mean over the shapes; their standard deviation):"]
    for r in seeded:
        each = ", ".join(number_text(v, 1e4) for v in r["d_R_seeds"])
        seeds = ", ".join(map(str, r.get("seeds") or range(len(r["d_R_seeds"]))))
        lines.append(f"- {r['method']}: {each} (seeds {seeds}; sd {number_text(r.get('d_R_std'), 1e4, 2)})")
    return lines


_HEADLINE_SPLITS = ("test", "test_subjects")


def headline_markdown(rows: list[dict], context: dict | None = None) -> list[str]:
    """The README's headline Table 1 (lines): each Table 1 method, and each row beside it, evaluated on all of
    ``test`` and ``test_subjects`` (not the networks of :data:`MAPPED_GROUPS`, nor the refinements and the entries of
    :data:`~opnet.experiments.plan.SUBSET_ENTRIES`, nor a row measured on fewer shapes of a split than others, as
    those of an older file without entries), its d_R (×10⁻⁴; :func:`value_text`: ``mean ± half-width`` for a row
    over seeds, and then a line under the table says so), mean d_V and d_E on ``test``, its d_R on ``test_subjects``
    and the paper's numbers; empty without Table 1 rows. With the file's ``context`` (what
    :func:`read_results` returns beside the rows), a last line says when, where and at which training budget the
    file was measured (:func:`provenance_text`).
    """
    t1 = [
        r
        for r in upgrade_rows(rows)
        if r.get("table") == "table1"
        and r.get("group") not in MAPPED_GROUPS
        and not r.get("refined")
        and r.get("entry") not in SUBSET_ENTRIES
    ]
    whole = {s: max((r.get("n_shapes", 0) for r in t1 if r["split"] == s), default=0) for s in _HEADLINE_SPLITS}
    t1 = [r for r in t1 if r.get("n_shapes", whole.get(r["split"], 0)) >= whole.get(r["split"], 0)]  # all shapes
    if not t1:
        return []
    lines = [
        "| method | test: d_R | d_V | d_E | unseen subjects: d_R | paper d_R / d_V / d_E |",
        "|---|---:|---:|---:|---:|---|",
    ]
    seeded = False  # whether a printed d_R has an interval
    for key in dict.fromkeys(row_key(r) for r in t1):
        test = next((r for r in t1 if row_key(r) == key and r["split"] == "test"), None)
        unseen = next((r for r in t1 if row_key(r) == key and r["split"] == "test_subjects"), None)
        if test is None:
            continue
        seeded |= any(r is not None and r.get("d_R_low") is not None for r in (test, unseen))
        paper = paper_table1(test)
        lines.append(
            f"| {test['method']} | {value_text(test, 'd_R', 1e4)} | {number_text(test['d_V'])} | "
            f"{number_text(test['d_E'])} | "
            f"{'–' if unseen is None else value_text(unseen, 'd_R', 1e4)} | "
            f"{'–' if paper is None else ' / '.join(f'{p:g}' for p in paper)} |"
        )
    if seeded:
        lines += ["", f"d_R ×10⁻⁴ m²; {_SEEDED} over seeds and shapes, the other columns the means."]
    if context:
        lines += ["", provenance_text(context)]
    return lines


def provenance_text(context: dict) -> str:
    """One sentence on a results file's ``context``: the dates of its calls (``earlier`` ones included), the
    machine, and the training budget of Table 1's networks (epochs, the learning rate as :func:`context_markdown`
    words it, batch size, seeds; a file written before schedules and seeds were recorded reads as a constant rate
    and one seed).
    """
    budget = context.get("budget") or {}
    dates = sorted({c["date"] for c in [*context.get("earlier", []), context] if c.get("date")})
    when = (
        "on an unrecorded date"
        if not dates
        else f"on {dates[0]}"
        if len(dates) == 1
        else f"from {dates[0]} to {dates[-1]}"
    )
    training = (
        f"{budget['epochs']} epochs, {_schedule_text(budget)}, batch {budget['batch_size']}{_seeds_text(context)}"
        if {"epochs", "lr", "batch_size"} <= budget.keys()
        else "an unrecorded budget"
    )
    return (
        f"Measured {when} on {context.get('machine', 'an unrecorded machine')}, at the "
        f"`{context.get('preset', '?')}` preset's budget then: {training}."
    )


def ablation_markdown(rows: list[dict], budget: dict, paper: bool = True) -> list[str]:
    """The ablation (lines): the depth × channels grid of d_R beside the paper's (``paper=False``: without it, for
    data the paper gives no numbers on), its caveat when the networks are barely trained, and whether the paper's
    trends hold; empty before the first ablation network. ``budget``: the reproduction's (``ablation_epochs``,
    ``epochs``), as a dict.
    """
    b = budget
    table, half = ablation_table(rows), ablation_table(rows, "half_width")
    if not np.isfinite(table).any():
        return []
    cols = ablation_columns(rows)
    lines = [
        f"Each network trained {_epochs(b['ablation_epochs'])} (Table 1's have {b['epochs']})"
        + (f"; {_SEEDED} over seeds and shapes." if np.isfinite(half).any() else "."),
        "",
        "| encoder | " + " | ".join(cols) + " |",
        "|---" * (len(cols) + 1) + "|",
    ]
    for i, d in enumerate(PAPER_ABLATION_DEPTHS):
        best = np.nanargmin(table[i]) if np.isfinite(table[i]).any() else -1
        cells = [
            (f"**{number_text(v)}**" if j == best else number_text(v))
            + (f" ± {number_text(h, digits=2)}" if np.isfinite(h) else "")
            for j, (v, h) in enumerate(zip(table[i], half[i]))
        ]
        lines.append(f"| {_encoder(d)} | " + " | ".join(cells) + " |")
    if paper:
        lines += [
            "",
            "The paper's (DFAUST):",
            "",
            "| encoder | " + " | ".join(cols) + " |",
            "|---" * (len(cols) + 1) + "|",
        ]
        for d, vals in PAPER_ABLATION.items():
            cells = [*(f"{v:g}" for v in vals), *(["–"] * (len(cols) - len(vals)))]  # none for sets of one's own
            lines.append(f"| {_encoder(d)} | " + " | ".join(cells) + " |")
    done = table[:, cols.index("A+E+C")]
    t1 = [r for r in rows if r.get("table") == "table1"]
    nn = (_find(t1, "test", **_NN) or {}).get("d_R")
    if nn is not None and np.nanmin(table) > 0.5e4 * nn:
        lines += [
            "",
            f"**Caveat:** with {_epochs(b['ablation_epochs'])} at this preset the ablation networks are barely "
            f"trained (every cell is above half of NN's {number_text(nn, 1e4)}), so the differences between cells are "
            "mostly noise: this table shows the pipeline, not the paper's trends. Use a larger preset.",
        ]
    if np.isfinite(table).all():
        best_col = np.mean(np.argmin(table, axis=1) == cols.index("A+E+C"))
        lines += [
            "",
            f"All three operators give the best column in {best_col:.0%} of the depths"
            f"{' (the paper: 100 %)' if paper else ''}; "
            f"depth 1 is {'the best' if np.argmin(done) == 0 else 'not the best'} for A+E+C "
            f"({', '.join(number_text(v) for v in done)} for depths 1–4).",
        ]
    return lines


def discretisation_markdown(rows: list[dict]) -> list[str]:
    """The different-discretisation section of ``results.md`` (lines, without its heading): d_R per encoding and
    network, and the target.
    """
    disc = [r for r in rows if r.get("table") == "discretisation"]
    if not disc:
        return []
    nets = list(dict.fromkeys(row_key(r) for r in disc))
    names = {key: next(r["method"] for r in disc if row_key(r) == key) for key in nets}
    encodings = list(dict.fromkeys((r["resolution"], r["maps"]) for r in disc))
    get = {(r["resolution"], r["maps"], row_key(r)): r for r in disc}
    lines = [
        f"{disc[0]['n_shapes']} `test` shapes (evenly spaced) generated on each mesh, mapped onto the 1k base "
        "by the generator's true correspondence or by a computed map (`opnet.matching.compute_map`), encoded "
        "through the map and decoded by each network; d_R ×10⁻⁴ against the 1k shapes (median in brackets; "
        f"{_SEEDED}). "
        "Map error: mean distance between where the computed and the true map send a vertex. *1k exact*: the "
        "same shapes' own operators."
        + "".join(
            sorted(
                {
                    f" {r['method']} decodes to the {r['labels']} mesh (the paper's appendix: finer labels from the "
                    f"1k operators) and is measured against the same shapes on it."
                    for r in disc
                    if r.get("labels")
                }
            )
        ),
        "",
        "| mesh | map | map error (cm) | " + " | ".join(names[n] for n in nets) + " |",
        "|---" * (3 + len(nets)) + "|",
    ]
    for res, maps in encodings:
        first = get[res, maps, nets[0]]
        cells = [
            f"{value_text(get[res, maps, n], 'd_R', 1e4)} ({number_text(get[res, maps, n]['d_R_median'], 1e4)})"
            if (res, maps, n) in get
            else "–"
            for n in nets
        ]
        error = "–" if maps == "exact" else f"{100 * first['map_error']:.2f}"
        lines.append(f"| {res} | {maps} | {error} | " + " | ".join(cells) + " |")
    for target in targets_of("discretisation"):
        verdicts = judge(target, disc)
        if verdicts:
            lines += [
                "",
                f"**Target:** {target.label} within {target.threshold:g}× of OperatorNet (Int+Ext)'s error on the "
                f"exact 1k operators of the same shapes ({number_text(verdicts[0].denominator, 1e4)}), for each "
                "network:",
                "",
            ]
            lines += [
                f"- {v.row['method']}: {number_text(v.numerator, 1e4)}, {v.value:.1f}×: {'met' if v.met else 'missed'}."
                for v in verdicts
            ]
    return lines


def applications_markdown(rows: list[dict], context: dict | None = None) -> list[str]:
    """The applications' section of ``results.md`` (lines, without its heading): the analogy and interpolation
    tables and their targets; ``context`` (the reproduction's) names the kinds for its data (humans by default).
    """
    p = _profile(context)
    kind_names = dict(analogy=p.analogy_kinds, interpolation=p.interpolation_kinds)
    ana = [r for r in rows if r.get("table") == "analogy"]
    itp = [r for r in rows if r.get("table") == "interpolation"]
    if not ana and not itp:
        return []
    lines = [
        "Subjects from `test_subjects`, poses from the `test` sequences; the true shapes are generated from the "
        "generator's parameters (`opnet.apps`). d_R ×10⁻⁴ (median in brackets; "
        f"{_SEEDED}, over seeds and questions or paths). *direct*: the same method on X given X itself (its floor: "
        "the rest is the algebra's error).",
    ]
    for kind in dict.fromkeys(r["kind"] for r in ana):
        part = [r for r in ana if r["kind"] == kind]
        lines += [
            "",
            f"**Analogy, {kind_names['analogy'].get(kind, kind)}** ({part[0]['n']} questions)",
            "",
            "| method | n | d_R | d_V | d_E | direct d_R |",
            "|---|---|---|---|---|---|",
        ]
        for r in part:
            before = f" (before: {number_text(r['d_R_before'], 1e4)})" if "d_R_before" in r else ""
            lines.append(
                f"| {r['method']} | {r['n']} | {value_text(r, 'd_R', 1e4)} "
                f"({number_text(r['d_R_median'], 1e4)}){before} | "
                f"{value_text(r, 'd_V')} | {value_text(r, 'd_E')} | {number_text(r['d_R_direct'], 1e4)} |"
            )
    for kind in dict.fromkeys(r["kind"] for r in itp):
        part = [r for r in itp if r["kind"] == kind]
        lines += [
            "",
            f"**Interpolation, {kind_names['interpolation'].get(kind, kind)}** ({part[0]['n_paths']} paths of "
            f"{part[0]['steps']} steps)",
            "",
            "| method | paths | endpoints d_R | in-between d_R | edge distortion | smoothness (worst) |",
            "|---|---|---|---|---|---|",
        ]
        for r in part:
            lines.append(
                f"| {r['method']} | {r['n_paths']} | {value_text(r, 'endpoint_d_R', 1e4)} | "
                f"{value_text(r, 'd_R_truth', 1e4)} | {value_text(r, 'distortion')} | {value_text(r, 'smoothness')} "
                f"({number_text(r['smoothness_max'])}) |"
            )
    if itp:
        lines += [
            "",
            f"Edge distortion: the largest mean relative edge-length error against the nearer true endpoint; "
            f"smoothness: the largest step over the path length ({1 / (itp[0]['steps'] - 1):.2f} for even steps).",
        ]
    verdicts = []
    measured = [v for t in targets_of("analogy") for v in judge(t, ana)]
    for kind in dict.fromkeys(r["kind"] for r in ana):
        part = [r for r in ana if r["kind"] == kind]
        ours = (_find(part, **_PAPER, scheme="multiplicative") or {}).get("d_R")
        mine = [v for v in measured if v.target.where["kind"] == kind]
        if mine:
            met = all(v.met for v in mine)
            ratios = ", ".join(f"{v.row['method']} / OperatorNet = {v.value:.2f}" for v in mine)
            verdict = f" (target: OperatorNet (mult.) beats both at `default`): {'met' if met else 'missed'}."
            verdicts.append(f"- analogy, {kind}: {ratios}" + (verdict if p.paper_numbers else "."))
        linear = (_find(part, **_PAPER, scheme="linear") or {}).get("d_R")
        if ours is not None and linear is not None:
            verdicts.append(
                f"- analogy, {kind}: the linear algebra's d_R / the multiplicative one's = {linear / ours:.2f}."
            )
    heading = "**Targets**" if p.paper_numbers else "**Ratios**"
    return lines + (["", heading, ""] + verdicts if verdicts else [])


def _verdict_line(v, paper: bool, scale: float = 1e4) -> str:
    """One line of ``results.md``'s targets: the measure, its numbers and, with ``paper``, the target and the paper's
    value.
    """
    t = v.target
    where = _SPLIT_NAMES.get(t.where.get("split"), t.where.get("split", ""))
    if t.denominator is None:
        return f"- {where}: {t.label} {number_text(v.value)} (target {'≥' if t.at_least else '≤'} {t.threshold:g}: " + (
            f"{'met' if v.met else 'missed'})."
        )
    numbers = f"{number_text(v.numerator, scale)} vs {number_text(v.denominator, scale)} ×10⁻⁴"
    if not paper:
        return f"- {where}: {t.label} = {v.value:.3g} ({numbers})."
    published = "" if t.paper is None else f", the paper {t.paper:.2g}"
    sign = "≥" if t.at_least else "≤"
    return (
        f"- {where}: {t.label} = {v.value:.3g} ({numbers}; target {sign} {t.threshold:g} at `default`{published}): "
        f"{'met' if v.met else 'missed'}."
    )


def targets(t1: list[dict], paper: bool = True) -> list[str]:
    """The verdicts on Table 1's targets (lines of ``results.md``) from its rows ``t1``: each target of
    :mod:`opnet.experiments.targets` on Table 1 (NN against OperatorNet per test set, d_V and d_E, the paper's network
    against ours, the "Comp" networks against the ground-truth maps), what refinement changes, FuncChar against the
    paper's, and the paper's ordering Int+Ext < Ext < Int. ``paper=False`` (data the paper gives no numbers on, the
    animals): the ratios alone, without targets or the paper's figures.
    """

    def get(fields, split, key="d_R"):
        r = _find(t1, split, **fields)
        return None if r is None else r.get(key)

    shown = [t for t in targets_of("table1") if paper or t.denominator is not None]  # the ratios, without the paper
    lines = [_verdict_line(v, paper) for t in shown for v in judge(t, t1)]
    for fields in (_PAPER, _OURS):
        net = _find(t1, "test", **fields)
        named = [] if net is None else net.get("runs") or [net.get("run")]  # a seeded row: one run per seed
        runs = [r for r in named if r is not None]
        refined = next((r for r in t1 if r["split"] == "test" and r.get("refined") and r.get("run") in runs), None)
        if refined is None or None in (refined.get("d_R"), refined.get("d_R_before")):
            continue
        after, before = refined["d_R"], refined["d_R_before"]
        which = f"seed {refined['seeds'][0]}'s " if len(runs) > 1 and len(refined.get("seeds") or ()) == 1 else ""
        lines.append(
            f"- test: refinement changes {which}{net['method']}'s d_R by {100 * (after / before - 1):+.0f} % "
            f"({number_text(before, 1e4)} → {number_text(after, 1e4)} ×10⁻⁴ on the same {refined['n_shapes']} shapes)."
        )
    truth = get(_PAPER, "test")
    reference = PAPER_TABLE1["OperatorNet (Int+Ext)"][0]
    funcchar, geometric = _find(t1, "test", baseline="funcchar"), _find(t1, "test", baseline="geometric")
    if funcchar is not None and truth is not None and paper:
        published = PAPER_TABLE1["FuncChar (Int+Ext)"][0] / reference
        other = f"; Geometric (A+E): {number_text(geometric['d_R'], 1e4)}" if geometric is not None else ""
        lines.append(
            f"- test: FuncChar (Int+Ext)'s d_R / OperatorNet (Int+Ext)'s = {funcchar['d_R'] / truth:.3g} "
            f"({number_text(funcchar['d_R'], 1e4)} on {funcchar['n_shapes']} shapes vs {number_text(truth, 1e4)} "
            "×10⁻⁴; the paper "
            f"{published:.3g}{other})."
        )
    order = [get(PAPER_TABLE1_ROWS[name], "test") for name in _ORDER]
    if None not in order:
        holds = order[0] < order[1] < order[2]
        lines.append(
            f"- ordering Int+Ext < Ext < Int on test (the paper's): {'holds' if holds else 'does not hold'} "
            f"({' / '.join(number_text(v, 1e4) for v in order)})."
        )
    return lines
