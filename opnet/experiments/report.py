"""The reproduction's report: rows (and their context) → ``results.md`` text, the targets' verdicts, the ablation's
table; :func:`write_results` writes ``results.json`` and ``results.md``.

Rows are found by their structured fields, never by their display name (``method``, shown as it is):

- runs (:meth:`opnet.experiments.RunSpec.fields`): ``run``, ``architecture``, ``variant``, ``channels`` (names; a
  comma-joined string in older files), ``depth``, and the spec's ``group`` (``"table1"``, ``"comp"``: trained
  through computed maps, ``"ablation"``);
- baselines: ``baseline`` (``"nearest_neighbour"``, ``"base_shape"``, ``"geometric"``);
- a network's output refined by :func:`opnet.reconstruct`: its run's fields (not its ``channels``: those of the
  refinement) and ``refined`` ``True``;
- the tables: ``table`` (``"table1"``, ``"ablation"``, ``"discretisation"``, ``"analogy"``, ``"interpolation"``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .._files import atomic_write
from ..evaluate import SPECIES_SETS, channel_label, channel_names
from ..shape_difference import KINDS
from .paper import PAPER_ABLATION, PAPER_ABLATION_DEPTHS, PAPER_ABLATION_SETS, PAPER_TABLE1
from .spec import RunSpec

__all__ = [
    "MAPPED_GROUPS",
    "write_results",
    "merge_results",
    "row_identity",
    "results_markdown",
    "results_sections",
    "SECTION_TITLES",
    "context_markdown",
    "table1_markdown",
    "headline_markdown",
    "ablation_markdown",
    "discretisation_markdown",
    "read_results",
    "RESULTS_FORMAT",
    "RESULTS_VERSION",
    "applications_markdown",
    "targets",
    "ablation_table",
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
_KIND_NAMES = {
    "analogy": {"pose": "pose transfer (a,p):(a,q)::(b,p):(b,q)", "body": "body transfer (a,p):(b,p)::(a,q):(b,q)"},
    "interpolation": {"pose": "one subject, pose to pose", "body": "one pose, subject to subject"},
}
#: The animals' names of the same kinds (the paper's Fig. 15: pose and animal-type transfer; its Fig. 8: tiger → horse).
_ANIMAL_KIND_NAMES = {
    "analogy": {
        "pose": "pose transfer (a,p):(a,q)::(b,p):(b,q)",
        "body": "animal-type transfer (a,p):(b,p)::(a,q):(b,q)",
    },
    "interpolation": {"pose": "one animal, frame to frame of a clip", "body": "one pose, species to species"},
}


def _is_humans(context: dict | None) -> bool:
    """Whether a reproduction ran on the humans (the paper's numbers apply) rather than the animals; files written
    before ``context["data"]`` existed are the humans'.
    """
    return (context or {}).get("data", "humans") == "humans"


def _network(channels, group: str = "table1") -> dict:
    """The fields of the paper's model (depth 1) on ``channels``, trained in ``group``, its output not refined."""
    return dict(architecture="operatornet", variant="paper", group=group, channels=channels, depth=1, refined=None)


#: The rows standing for each row of the paper's Table 1 (:data:`~opnet.experiments.paper.PAPER_TABLE1`): the fields
#: they have (:func:`matches`).
PAPER_TABLE1_ROWS = {
    "OperatorNet (Int+Ext)": _network(KINDS),
    "OperatorNet (Int)": _network(("area", "conformal")),
    "OperatorNet (Ext)": _network(("extrinsic",)),
    "Nearest neighbour (Int+Ext)": dict(baseline="nearest_neighbour", channels=KINDS),
    "OperatorNet (Comp)(Ext)": _network(("extrinsic",), "comp"),
    "OperatorNet (Comp)(Int+Ext)": _network(KINDS, "comp"),
    "FuncChar (Int+Ext)": dict(baseline="funcchar"),
}
#: The groups of the networks trained and tested on operators through computed maps (Table 1's "Comp" rows and the
#: rows beside them, ``opnet.reproduce.COMP_HALF`` and ``COMP_THREE``): the README's headline leaves them out, as
#: the paper's does.
MAPPED_GROUPS = ("comp", "comp-half", "comp-three")
_PAPER = PAPER_TABLE1_ROWS["OperatorNet (Int+Ext)"]  # the paper's network: Table 1's reference
_OURS = dict(_PAPER, variant="ours")  # this project's variant, on the same input
_NN = PAPER_TABLE1_ROWS["Nearest neighbour (Int+Ext)"]


def row_channels(row: dict) -> tuple[str, ...]:
    """The channel names of a row: its ``channels`` list, or the comma-joined string of older ``results.json``."""
    return channel_names(row.get("channels") or ())


def matches(row: dict, **fields) -> bool:
    """Whether ``row`` has each of ``fields`` (``None``: the field is absent or ``None``); ``channels`` are compared
    as sets of names (:func:`row_channels`).
    """
    for key, want in fields.items():
        if key == "channels":
            if set(row_channels(row)) != set(channel_names(want)):
                return False
        elif row.get(key) != want:
            return False
    return True


def _legacy_fields() -> dict:
    """Method name → structured fields, for the rows of a ``results.json`` written before rows had them.

    Older reproductions named each row by its display name alone, always from this fixed list; an exact lookup in
    it (never a parse) gives those rows the fields of the runs and baselines they stand for.
    """
    runs = {
        "OperatorNet (Int+Ext)": RunSpec(KINDS, group="table1"),
        "OperatorNet (Int)": RunSpec(("area", "conformal"), group="table1"),
        "OperatorNet (Ext)": RunSpec(("extrinsic",), group="table1"),
        "OperatorNet ours (Int+Ext)": RunSpec(KINDS, variant="ours", group="table1"),
        "OperatorNet (Comp)(Int+Ext)": RunSpec(KINDS, group="comp"),
        "OperatorNet (Comp)(Ext)": RunSpec(("extrinsic",), group="comp"),
        "PointNet AE": RunSpec(architecture="pointnet", group="table1"),
    }
    fields = {name: spec.fields() for name, spec in runs.items()}
    no_channels = {k: v for k, v in fields["OperatorNet (Int+Ext)"].items() if k != "channels"}
    fields |= {f"{name} + refinement": dict(fields[name], refined=True) for name in list(fields)}
    fields |= {  # the applications' methods (their rows carry ``scheme``)
        "OperatorNet (mult.)": no_channels,
        "OperatorNet (linear)": no_channels,
        "OperatorNet (mult.) + refinement": dict(no_channels, refined=True),
        "OperatorNet ours (mult.)": {k: v for k, v in fields["OperatorNet ours (Int+Ext)"].items() if k != "channels"},
    }
    baselines = {"Nearest neighbour (Int+Ext)", "Nearest neighbour"}
    fields |= {name: dict(baseline="nearest_neighbour") for name in baselines}
    return fields | {"Base shape": dict(baseline="base_shape"), "Geometric (A+E)": dict(baseline="geometric")}


def upgrade_rows(rows: list[dict]) -> list[dict]:
    """``rows`` with the structured fields filled in where an older ``results.json`` lacks them.

    A row without ``run`` and ``baseline`` (written before rows had them) gets the fields of the method it is named
    for (an exact lookup in the fixed list of names older reproductions wrote); rows that have them, and names
    that are not in the list, are returned as they are (the latter still tell themselves apart by :func:`row_key`).
    """
    legacy = _legacy_fields()
    return [{**legacy.get(r.get("method"), {}), **r} if "run" not in r and "baseline" not in r else r for r in rows]


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


def ablation_table(rows) -> np.ndarray:
    """The ablation's d_R ×10⁻⁴ on ``test`` as a ``(depths, sets)`` array (NaN where not trained yet): rows
    ``PAPER_ABLATION_DEPTHS``, columns ``PAPER_ABLATION_SETS`` (the paper's grid, which the reproduction trains).
    """
    table = np.full((len(PAPER_ABLATION_DEPTHS), len(PAPER_ABLATION_SETS)), np.nan)
    for r in rows:
        if r.get("table") == "ablation":
            names = row_channels(r)
            column = next(i for i, v in enumerate(PAPER_ABLATION_SETS.values()) if set(v) == set(names))
            table[PAPER_ABLATION_DEPTHS.index(r["depth"]), column] = 1e4 * r["d_R"]
    return table


def _fmt(v, scale=1.0, digits=3) -> str:
    return "–" if v is None or not np.isfinite(v) else f"{scale * v:.{digits}g}"


#: What ``results.json`` holds: ``{"format": RESULTS_FORMAT, "version": RESULTS_VERSION, "context", "rows"}``.
RESULTS_FORMAT, RESULTS_VERSION = "opnet.results", 2


def write_results(out: Path, rows: list[dict], context: dict, seconds: float) -> None:
    """Write ``out/results.json`` (the rows and ``context`` with ``wall_seconds`` = ``seconds``: all that
    :func:`results_markdown` needs) and ``out/results.md`` (that Markdown), each atomically.
    """
    context = dict(context, wall_seconds=round(seconds, 1))
    data = dict(format=RESULTS_FORMAT, version=RESULTS_VERSION, context=context, rows=rows)
    atomic_write(out / "results.json", lambda f: f.write(json.dumps(data, indent=1).encode()))
    md = results_markdown(rows, context)
    atomic_write(out / "results.md", lambda f: f.write(md.encode()))


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
    measure again (their :func:`row_identity` is not among ``rows``) are kept, in their place (a re-measured row
    takes its old one's place, new ones come last), so that a call with fewer parts (``--no-ablation``,
    ``--no-maps`` ...) adds to the folder's results instead of losing them; ``context`` then lists under
    ``"earlier"`` the earlier call (its date, machine, wall time and the tables of the rows kept) and the calls it
    listed itself: a chain of calls is listed whole, without telling which of them measured each kept row.
    Results of another preset, budget or collection are not merged (a warning says so): ``(rows, context)`` are
    returned as they are.
    """
    if not earlier or earlier[1] is None:
        return rows, context
    old_rows, old = earlier
    same = ("preset", "budget", "collection", "splits")
    if any(old.get(key) != context.get(key) for key in same):
        import warnings

        warnings.warn(
            f"results.json holds {len(old_rows)} rows of another preset, budget or collection; they are replaced, "
            "not merged (run into another folder to keep them).",
            stacklevel=2,
        )
        return rows, context
    new = {row_identity(r): r for r in rows}
    old_ids = [row_identity(r) for r in old_rows]
    merged = [new.get(i, r) for i, r in zip(old_ids, old_rows)]  # re-measured rows replace theirs, in place
    kept = [r for i, r in zip(old_ids, old_rows) if i not in new]
    seen = set(old_ids)
    merged += [r for i, r in new.items() if i not in seen]  # this call's new rows, in its order
    if not kept:
        return merged, context
    summary = {key: old[key] for key in ("date", "machine", "wall_seconds") if key in old}
    summary["tables"] = sorted({str(r.get("table")) for r in kept})
    return merged, dict(context, earlier=[*old.get("earlier", []), summary])


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
    "table1": "Table 1: shape reconstruction",
    "targets": "Targets",
    "ablation": "Ablation (Appendix B): d_R ×10⁻⁴ on `test`",
    "discretisation": "Other triangulations: test shapes on 2k and 5k meshes",
    "applications": "Applications: analogy and interpolation against ground truth",
}


def results_sections(rows: list[dict], context: dict) -> dict[str, list[str]]:
    """The sections of ``results.md``, name → Markdown lines without their heading (:data:`SECTION_TITLES`): the
    ``context`` (machine, data, training), ``table1``, its ``targets``, the ``ablation``, the ``discretisation``
    rows and the ``applications``; a section without rows is left out. The docs' results page shows the shipped
    reproduction's sections one by one.
    """
    rows = upgrade_rows(rows)
    t1 = [r for r in rows if r.get("table") == "table1"]
    humans = _is_humans(context)
    sections = {"context": context_markdown(context), "table1": table1_markdown(rows, paper=humans)}
    sections |= {"targets": targets(t1, paper=humans), "ablation": ablation_markdown(rows, context["budget"], humans)}
    other_meshes = discretisation_markdown(rows) if humans else []  # the humans' 2k and 5k meshes
    sections |= {"discretisation": other_meshes, "applications": applications_markdown(rows, context)}
    return {name: lines for name, lines in sections.items() if lines}


def context_markdown(context: dict) -> list[str]:
    """What a reproduction ran on (lines): the machine, the wall time, the data and the training settings."""
    b = context["budget"]
    when = f" on {context['date']} (opnet {context['opnet_version']})" if "date" in context else ""
    return [
        f"Machine: {context['machine']}{when}. Wall time so far: {context['wall_seconds']:.0f} s "
        "(data, training, evaluation; finished runs are reused, so a resumed call counts only what it did).",
        "",
        *[
            f"Rows kept from an earlier call in the same folder (its finished runs reused): the tables "
            f"{', '.join(e['tables'])}, measured{' on ' + e['date'] if 'date' in e else ''} on {e.get('machine', '?')}"
            f"{', wall time {:.0f} s'.format(e['wall_seconds']) if 'wall_seconds' in e else ''}."
            for e in context.get("earlier", [])
        ],
        *([""] if context.get("earlier") else []),
        f"Data: {context['collection']}; the furthest-point evaluation subset (the paper's 50 shapes: 5 per held-out "
        f"sequence) has {context['eval_subset']} shapes.",
        "",
        f"Training: Adam, lr {b['lr']}, batch {b['batch_size']}, {b['epochs']} epochs for Table 1's OperatorNets "
        f"({b.get('pointnet_epochs', b['epochs'])} for the PointNet AE) and {b['ablation_epochs']} for the ablation "
        "(fewer, to keep the 28-network grid affordable); model "
        "selection on `val`. "
        + (
            "The paper's numbers are on DFAUST, ours on `anny` humans: the scale (metres) is alike, the data are "
            "not the same."
            if _is_humans(context)
            else "The shapes: the animals of `opnet.data.animals` (Quaternius' quadrupeds on the horse's template, "
            "species and blends between them; `test_subjects` holds held-out blends and the wolf, a species never "
            'seen in training; "unseen species" is the wolf alone). The paper trains on SMAL animals but publishes '
            "no numbers for them."
        ),
    ]


def table1_markdown(rows: list[dict], paper: bool = True) -> list[str]:
    """Table 1 (lines): every method's d_R, d_V and d_E per test set beside the paper's (``paper=False``: without
    the paper's columns, for data the paper gives no numbers on), its training time and its time per shape; empty
    without Table 1 rows.
    """
    t1 = [r for r in upgrade_rows(rows) if r.get("table") == "table1"]
    if not t1:
        return []
    lines = ["d_R ×10⁻⁴ (m²), mean (median in brackets).", ""]
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
                [f"{_fmt(r['d_R'], 1e4)} ({_fmt(r['d_R_median'], 1e4)})", _fmt(r["d_V"]), _fmt(r["d_E"])]
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
            + f" | {'–' if secs is None else f'{secs:.0f}'} | {_fmt(per_shape, digits=2)} |"
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
    return lines


def headline_markdown(rows: list[dict]) -> list[str]:
    """The README's headline Table 1 (lines): each Table 1 method, and each row beside it, evaluated on all of
    ``test`` and ``test_subjects`` (not the networks of :data:`MAPPED_GROUPS`, nor the operator-matching rows, which
    run on a subset), its mean d_R (×10⁻⁴), d_V and d_E on ``test``, its mean d_R on ``test_subjects`` and the
    paper's numbers; empty without Table 1 rows.
    """
    t1 = [
        r
        for r in upgrade_rows(rows)
        if r.get("table") == "table1"
        and r.get("group") not in MAPPED_GROUPS
        and not r.get("refined")
        and r.get("baseline") not in ("geometric", "funcchar")
    ]
    if not t1:
        return []
    lines = [
        "| method | test: d_R | d_V | d_E | unseen subjects: d_R | paper d_R / d_V / d_E |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for key in dict.fromkeys(row_key(r) for r in t1):
        test = next((r for r in t1 if row_key(r) == key and r["split"] == "test"), None)
        unseen = next((r for r in t1 if row_key(r) == key and r["split"] == "test_subjects"), None)
        if test is None:
            continue
        paper = paper_table1(test)
        lines.append(
            f"| {test['method']} | {_fmt(test['d_R'], 1e4)} | {_fmt(test['d_V'])} | {_fmt(test['d_E'])} | "
            f"{_fmt(None if unseen is None else unseen['d_R'], 1e4)} | "
            f"{'–' if paper is None else ' / '.join(f'{p:g}' for p in paper)} |"
        )
    return lines


def ablation_markdown(rows: list[dict], budget: dict, paper: bool = True) -> list[str]:
    """The ablation (lines): the depth × channels grid of d_R beside the paper's (``paper=False``: without it, for
    data the paper gives no numbers on), its caveat when the networks are barely trained, and whether the paper's
    trends hold; empty before the first ablation network. ``budget``: the reproduction's (``ablation_epochs``,
    ``epochs``), as a dict.
    """
    b = budget
    table = ablation_table(rows)
    if not np.isfinite(table).any():
        return []
    cols = list(PAPER_ABLATION_SETS)
    lines = [
        f"Each network trained {b['ablation_epochs']} epochs (Table 1's have {b['epochs']}).",
        "",
        "| encoder | " + " | ".join(cols) + " |",
        "|---" * (len(cols) + 1) + "|",
    ]
    for i, d in enumerate(PAPER_ABLATION_DEPTHS):
        best = np.nanargmin(table[i]) if np.isfinite(table[i]).any() else -1
        cells = [f"**{_fmt(v)}**" if j == best else _fmt(v) for j, v in enumerate(table[i])]
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
            lines.append(f"| {_encoder(d)} | " + " | ".join(f"{v:g}" for v in vals) + " |")
    done = table[:, -1]
    t1 = [r for r in rows if r.get("table") == "table1"]
    nn = (_find(t1, "test", **_NN) or {}).get("d_R")
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
            f"All three operators give the best column in {best_col:.0%} of the depths"
            f"{' (the paper: 100 %)' if paper else ''}; "
            f"depth 1 is {'the best' if np.argmin(done) == 0 else 'not the best'} for A+E+C "
            f"({', '.join(_fmt(v) for v in done)} for depths 1–4).",
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
        "through the map and decoded by each network; d_R ×10⁻⁴ against the 1k shapes (median in brackets). "
        "Map error: mean distance between where the computed and the true map send a vertex. *1k exact*: the "
        "same shapes' own operators.",
        "",
        "| mesh | map | map error (cm) | " + " | ".join(names[n] for n in nets) + " |",
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
    exact = _find([r for r in disc if (r["resolution"], r["maps"]) == ("1k", "exact")], **_PAPER)
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


def applications_markdown(rows: list[dict], context: dict | None = None) -> list[str]:
    """The applications' section of ``results.md`` (lines, without its heading): the analogy and interpolation
    tables and their targets; ``context`` (the reproduction's) names the kinds for its data (humans by default).
    """
    kind_names = _KIND_NAMES if _is_humans(context) else _ANIMAL_KIND_NAMES
    ana = [r for r in rows if r.get("table") == "analogy"]
    itp = [r for r in rows if r.get("table") == "interpolation"]
    if not ana and not itp:
        return []
    lines = [
        "Subjects from `test_subjects`, poses from the `test` sequences; the true shapes are generated from the "
        "generator's parameters (`opnet.apps`). d_R ×10⁻⁴ (median in brackets). *direct*: the same method on "
        "X given X itself (its floor: the rest is the algebra's error).",
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
            before = f" (before: {_fmt(r['d_R_before'], 1e4)})" if "d_R_before" in r else ""
            lines.append(
                f"| {r['method']} | {r['n']} | {_fmt(r['d_R'], 1e4)} ({_fmt(r['d_R_median'], 1e4)}){before} | "
                f"{_fmt(r['d_V'])} | {_fmt(r['d_E'])} | {_fmt(r['d_R_direct'], 1e4)} |"
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
                f"| {r['method']} | {r['n_paths']} | {_fmt(r['endpoint_d_R'], 1e4)} | {_fmt(r['d_R_truth'], 1e4)} | "
                f"{_fmt(r['distortion'])} | {_fmt(r['smoothness'])} ({_fmt(r['smoothness_max'])}) |"
            )
    if itp:
        lines += [
            "",
            f"Edge distortion: the largest mean relative edge-length error against the nearer true endpoint; "
            f"smoothness: the largest step over the path length ({1 / (itp[0]['steps'] - 1):.2f} for even steps).",
        ]
    verdicts = []
    for kind in dict.fromkeys(r["kind"] for r in ana):
        part = [r for r in ana if r["kind"] == kind]
        ours = (_find(part, **_PAPER, scheme="multiplicative") or {}).get("d_R")
        others = [_find(part, architecture="pointnet", refined=None), _find(part, baseline="nearest_neighbour")]
        others = {r["method"]: r["d_R"] for r in others if r is not None}
        if ours is not None and others:
            met = all(v > ours for v in others.values())
            ratios = ", ".join(f"{m} / OperatorNet = {v / ours:.2f}" for m, v in others.items())
            verdict = f" (target: OperatorNet (mult.) beats both at `default`): {'met' if met else 'missed'}."
            verdicts.append(f"- analogy, {kind}: {ratios}" + (verdict if _is_humans(context) else "."))
        linear = (_find(part, **_PAPER, scheme="linear") or {}).get("d_R")
        if ours is not None and linear is not None:
            verdicts.append(
                f"- analogy, {kind}: the linear algebra's d_R / the multiplicative one's = {linear / ours:.2f}."
            )
    heading = "**Targets**" if _is_humans(context) else "**Ratios**"
    return lines + (["", heading, ""] + verdicts if verdicts else [])


def targets(t1: list[dict], paper: bool = True) -> list[str]:
    """The verdicts on Table 1's targets (lines of ``results.md``) from its rows ``t1``: NN against OperatorNet per
    test set, d_V and d_E, the paper's network against ours, what refinement changes, the "Comp" networks against the
    ground-truth maps, and the paper's ordering Int+Ext < Ext < Int. ``paper=False`` (data the paper gives no numbers
    on, the animals): the same ratios, without targets or the paper's figures.
    """

    def get(fields, split, key="d_R"):
        r = _find(t1, split, **fields)
        return None if r is None else r.get(key)

    lines = []
    for split in ("test", "test_subjects", "unseen_species", "eval_subset"):
        ours, nn = get(_PAPER, split), get(_NN, split)
        if ours is not None and nn is not None:
            ratio = nn / ours
            verdict = (
                f"; target ≥ 10 at `default`, the paper 23): {'met' if ratio >= 10 else 'missed'}." if paper else ")."
            )
            lines.append(
                f"- {_SPLIT_NAMES[split]}: NN's d_R / OperatorNet (Int+Ext)'s = {ratio:.3g} "
                f"({_fmt(nn, 1e4)} vs {_fmt(ours, 1e4)} ×10⁻⁴{verdict}"
            )
    dv, de = get(_PAPER, "test", "d_V"), get(_PAPER, "test", "d_E")
    if dv is not None and paper:
        lines.append(
            f"- test: d_V {_fmt(dv)} (target ≤ 0.014: {'met' if dv <= 0.014 else 'missed'}), "
            f"d_E {_fmt(de)} (target ≤ 0.045: {'met' if de <= 0.045 else 'missed'})."
        )
    theirs, ours = get(_PAPER, "test"), get(_OURS, "test")
    if theirs is not None and ours is not None:
        verdict = f"; target ≥ 1.5 at `default`): {'met' if theirs / ours >= 1.5 else 'missed'}." if paper else ")."
        lines.append(
            f"- test: OperatorNet (Int+Ext)'s d_R / ours = {theirs / ours:.2f} ({_fmt(theirs, 1e4)} vs "
            f"{_fmt(ours, 1e4)} ×10⁻⁴{verdict}"
        )
    for fields in (_PAPER, _OURS):
        net = _find(t1, **fields)
        refined = None if net is None else dict(run=net.get("run"), refined=True)
        if refined is None:
            continue
        after, before = get(refined, "test"), get(refined, "test", "d_R_before")
        if after is not None and before is not None:
            lines.append(
                f"- test: refinement changes {net['method']}'s d_R by {100 * (after / before - 1):+.0f} % "
                f"({_fmt(before, 1e4)} → {_fmt(after, 1e4)} ×10⁻⁴ on the same shapes)."
            )
    truth = get(_PAPER, "test")
    reference = PAPER_TABLE1["OperatorNet (Int+Ext)"][0]
    funcchar, geometric = _find(t1, "test", baseline="funcchar"), _find(t1, "test", baseline="geometric")
    if funcchar is not None and truth is not None and paper:
        published = PAPER_TABLE1["FuncChar (Int+Ext)"][0] / reference
        other = f"; Geometric (A+E): {_fmt(geometric['d_R'], 1e4)}" if geometric is not None else ""
        lines.append(
            f"- test: FuncChar (Int+Ext)'s d_R / OperatorNet (Int+Ext)'s = {funcchar['d_R'] / truth:.3g} "
            f"({_fmt(funcchar['d_R'], 1e4)} on {funcchar['n_shapes']} shapes vs {_fmt(truth, 1e4)} ×10⁻⁴; the paper "
            f"{published:.3g}{other})."
        )
    for comp_row in (r for r in t1 if paper and r["split"] == "test" and matches(r, group="comp", refined=None)):
        channels = row_channels(comp_row)
        comp, same = comp_row.get("d_R"), get(_network(channels), "test")
        if comp is not None and truth is not None:
            published = paper_table1(comp_row)
            theirs = "–" if published is None else f"{published[0] / reference:.1f}"
            alike = f"; {comp / same:.1f}× OperatorNet ({channel_label(channels)})'s" if same is not None else ""
            lines.append(
                f"- test: {comp_row['method']}'s d_R / OperatorNet (Int+Ext)'s (ground-truth maps) = "
                f"{comp / truth:.1f} ({_fmt(comp, 1e4)} vs {_fmt(truth, 1e4)} ×10⁻⁴; target ≤ 5 at `default`, the "
                f"paper {theirs}{alike}): {'met' if comp / truth <= 5 else 'missed'}."
            )
    order = [get(_network(c), "test") for c in (KINDS, ("extrinsic",), ("area", "conformal"))]
    if None not in order:
        holds = order[0] < order[1] < order[2]
        lines.append(
            f"- ordering Int+Ext < Ext < Int on test (the paper's): {'holds' if holds else 'does not hold'} "
            f"({' / '.join(_fmt(v, 1e4) for v in order)})."
        )
    return lines
