"""The paper's quantitative claims, and this project's own, as records judged on rows.

A :class:`Claim` says that one method (the rows with the fields ``better``) has a lower ``metric`` than another
(``worse``), or than ``factor`` times it ("within 5× of": ``factor=5``; "ten times better": ``factor=0.1``), on some
rows (``table`` and ``where``: a split, or an application's kind), and where it comes from.
:func:`judge` measures it on rows:

- ``confirmed``: the paired comparison's interval (:func:`opnet.experiments.stats.compare`: the same shapes, seed
  by seed) lies wholly on the claim's side;
- ``refuted``: it lies wholly on the other side;
- ``inconclusive``: it holds 0, or the rows carry no per-shape errors (one training and its means alone, as
  reproductions wrote before seeds were part of a run): the means are given, but no interval, so no verdict.

The verdict is measured, never written by hand; :func:`claims_markdown` lays the verdicts out as a table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from .paper import PAPER_ABLATION, PAPER_ABLATION_SETS, PAPER_TABLE1
from .plan import PAPER_ROWS
from .rows import as_rows, matches, number_text

__all__ = ["Claim", "Judged", "CLAIMS", "VERDICTS", "judge", "judge_all", "claims_markdown"]

#: The verdicts of a claim.
VERDICTS = ("confirmed", "refuted", "inconclusive")

_INT_EXT, _INT, _EXT = (PAPER_ROWS[f"OperatorNet ({c})"] for c in ("Int+Ext", "Int", "Ext"))
_NN = PAPER_ROWS["Nearest neighbour (Int+Ext)"]
_ABLATION = dict(table="ablation", architecture="operatornet", variant="paper", group="ablation")


@dataclass(frozen=True)
class Claim:
    """One claim: the rows with the fields ``better`` have a lower ``metric`` than those with ``worse``.

    ``table`` and ``where`` (fields both rows share: ``split``, ``kind``) say which rows; ``source`` where the claim
    is made (the paper's table or figure, or this project's docs); ``paper``: the paper's own numbers for it, as
    text; ``ours``: a claim of this project rather than the paper's; ``factor``: the claim is ``better < factor ×
    worse`` (default 1).
    """

    key: str
    statement: str
    better: dict = field(hash=False)
    worse: dict = field(hash=False)
    source: str
    metric: str = "d_R"
    table: str = "table1"
    where: dict = field(default_factory=lambda: dict(split="test"), hash=False)
    paper: str = ""
    ours: bool = False
    factor: float = 1.0

    def __post_init__(self):
        if not (isinstance(self.key, str) and self.key):
            raise ValueError(f"key must be a non-empty string naming the claim, got {self.key!r}.")
        for name in ("better", "worse", "where"):
            if not isinstance(getattr(self, name), Mapping):
                raise ValueError(
                    f"{name} must be the fields (a dict) of the rows it names, e.g. {{'entry': 'int+ext'}}, got "
                    f"{getattr(self, name)!r}."
                )
        if not (isinstance(self.metric, str) and self.metric):
            raise ValueError(f"metric must be the name of a row's metric, e.g. 'd_R', got {self.metric!r}.")
        factor = self.factor
        if isinstance(factor, bool) or not (isinstance(factor, (int, float)) and 0 < factor < float("inf")):
            raise ValueError(f"factor must be a number > 0 (1: a plain comparison), got {factor!r}.")


@dataclass(frozen=True)
class Judged:
    """A claim measured on rows: the two means, the comparison (``None`` without per-shape errors) and the verdict;
    ``missing``: the claim's rows are not all there (nothing is judged).
    """

    claim: Claim
    verdict: str
    better_mean: float | None = None
    worse_mean: float | None = None
    comparison: object = None
    missing: bool = False


def _depth(d: int) -> dict:
    return dict(_ABLATION, channels=PAPER_ABLATION_SETS["A+E+C"], depth=d)


#: The claims (the paper's first, then this project's).
CLAIMS = (
    Claim(
        "int+ext-below-ext",
        "The extrinsic operator helps: Int+Ext reconstructs better than Ext alone",
        _INT_EXT,
        _EXT,
        "Table 1",
        paper=f"{PAPER_TABLE1['OperatorNet (Int+Ext)'][0]} < {PAPER_TABLE1['OperatorNet (Ext)'][0]}",
    ),
    Claim(
        "ext-below-int",
        "The extrinsic operator alone beats the two intrinsic ones",
        _EXT,
        _INT,
        "Table 1",
        paper=f"{PAPER_TABLE1['OperatorNet (Ext)'][0]} < {PAPER_TABLE1['OperatorNet (Int)'][0]}",
    ),
    Claim(
        "nn-far-behind",
        "OperatorNet reconstructs better than the nearest training shape (NN)",
        _INT_EXT,
        _NN,
        "Table 1",
        paper=f"{PAPER_TABLE1['OperatorNet (Int+Ext)'][0]} < {PAPER_TABLE1['Nearest neighbour (Int+Ext)'][0]}",
    ),
    Claim(
        "nn-ten-times-behind",
        "NN is far behind: OperatorNet's error is under a tenth of NN's",
        _INT_EXT,
        _NN,
        "Table 1",
        paper=f"{PAPER_TABLE1['OperatorNet (Int+Ext)'][0]} < 0.1 × {PAPER_TABLE1['Nearest neighbour (Int+Ext)'][0]}",
        factor=0.1,
    ),
    *(
        Claim(
            f"comp-{short}-close-to-exact",
            f"Through computed maps, OperatorNet ({label}) stays within 5× of its error on exact operators",
            PAPER_ROWS[f"OperatorNet (Comp)({label})"],
            PAPER_ROWS[f"OperatorNet ({label})"],
            "Table 1 (Comp rows)",
            paper=f"{PAPER_TABLE1[f'OperatorNet (Comp)({label})'][0]} < 5 × "
            f"{PAPER_TABLE1[f'OperatorNet ({label})'][0]}",
            factor=5.0,
        )
        for short, label in (("int+ext", "Int+Ext"), ("ext", "Ext"))
    ),
    Claim(
        "funcchar-offset-helps",
        "FuncChar's offset surface helps: FuncChar (Int+Ext) reconstructs better than FuncChar (Int)",
        PAPER_ROWS["FuncChar (Int+Ext)"],
        PAPER_ROWS["FuncChar (Int)"],
        "Table 1",
        paper=f"{PAPER_TABLE1['FuncChar (Int+Ext)'][0]} < {PAPER_TABLE1['FuncChar (Int)'][0]}",
    ),
    Claim(
        "sfl-best-d_E",
        "Given the full Laplacian, SfL keeps edge lengths better than OperatorNet (Int+Ext) (the paper: its best d_E)",
        PAPER_ROWS["SfL"],
        _INT_EXT,
        "Table 1",
        metric="d_E",
        paper=f"{PAPER_TABLE1['SfL'][2]} < {PAPER_TABLE1['OperatorNet (Int+Ext)'][2]}",
    ),
    Claim(
        "operatornet-beats-sfl",
        "OperatorNet (Int+Ext) reconstructs far better than SfL given the full Laplacian (d_R)",
        _INT_EXT,
        PAPER_ROWS["SfL"],
        "Table 1",
        paper=f"{PAPER_TABLE1['OperatorNet (Int+Ext)'][0]} < {PAPER_TABLE1['SfL'][0]}",
    ),
    Claim(
        "sfl-d_E-below-nn",
        "Given the full Laplacian, SfL keeps edge lengths better than NN (the paper's next best d_E)",
        PAPER_ROWS["SfL"],
        _NN,
        "Table 1",
        metric="d_E",
        paper=f"{PAPER_TABLE1['SfL'][2]} < {PAPER_TABLE1['Nearest neighbour (Int+Ext)'][2]}",
    ),
    *(
        Claim(
            f"operatornet-beats-{key}",
            f"OperatorNet (Int+Ext) reconstructs better than {row}'s geometric reconstruction",
            _INT_EXT,
            PAPER_ROWS[row],
            "Table 1",
            paper=f"{PAPER_TABLE1['OperatorNet (Int+Ext)'][0]} < {PAPER_TABLE1[row][0]}",
        )
        for key, row in (("funcchar", "FuncChar (Int+Ext)"), ("funcchar-int", "FuncChar (Int)"))
    ),
    Claim(
        "5k-funcchar-behind",
        "On 5k inputs through computed maps, OperatorNet (Int+Ext) reconstructs better than FuncChar's geometric "
        "reconstruction, which stays near the base",
        dict(_INT_EXT, resolution="5k", maps="computed"),
        dict(baseline="funcchar", resolution="5k", maps="computed"),
        "Appendix, Fig. 12 (shapes of other discretisations)",
        table="discretisation",
    ),
    Claim(
        "5k-to-1k",
        "Test shapes given on 5k meshes, through computed maps, decode within 3× of their exact 1k operators' error",
        dict(_INT_EXT, resolution="5k", maps="computed"),
        dict(_INT_EXT, resolution="1k", maps="exact"),
        "Section 6.2 and Fig. 7 (5k → 1k); the 3× is this project's target",
        table="discretisation",
        factor=3.0,
    ),
    Claim(
        "nn-far-behind-unseen",
        "OperatorNet reconstructs unseen subjects better than NN",
        _INT_EXT,
        _NN,
        "this project's unseen subjects (`test_subjects`)",
        where=dict(split="test_subjects"),
        ours=True,
    ),
    *(
        Claim(
            f"depth-1-below-{d}",
            f"Depth 1 beats depth {d} on all three operators",
            _depth(1),
            _depth(d),
            "Appendix B",
            table="ablation",
            paper=f"{PAPER_ABLATION[1][-1]} < {PAPER_ABLATION[d][-1]}",
        )
        for d in (2, 3, 4)
    ),
    *(
        Claim(
            f"all-three-below-{name}",
            f"At depth 1 all three operators beat {name}",
            _depth(1),
            dict(_ABLATION, channels=channels, depth=1),
            "Appendix B",
            table="ablation",
            paper=f"{PAPER_ABLATION[1][-1]} < {PAPER_ABLATION[1][list(PAPER_ABLATION_SETS).index(name)]}",
        )
        for name, channels in PAPER_ABLATION_SETS.items()
        if name != "A+E+C"
    ),
    *(
        Claim(
            f"analogy-{kind}-below-pointnet",
            f"Analogies ({kind} transfer) are answered better than by the PointNet autoencoder",
            dict(_INT_EXT, scheme="multiplicative"),
            dict(architecture="pointnet", refined=None),
            "Fig. 10; Appendix D, Figs. 13-14",
            table="analogy",
            where=dict(kind=kind),
        )
        for kind in ("pose", "body", "gender")
    ),
    *(
        Claim(
            f"interpolation-{kind}-smoother-than-{other}",
            f"Interpolation ({kind} paths) is smoother than {other}'s (the largest step over the path length)",
            dict(_INT_EXT, scheme="multiplicative"),
            fields,
            source,
            metric="smoothness",
            table="interpolation",
            where=dict(kind=kind),
        )
        for kind in ("pose", "body")
        for other, fields, source in (
            (
                "the PointNet autoencoder",
                dict(architecture="pointnet", refined=None),
                "Figs. 1 and 9; Appendix E, Fig. 16 (the linear algebra)",
            ),
            (
                "the linear algebra",
                dict(_INT_EXT, scheme="linear"),
                "Figs. 1 and 9; Appendix E, Fig. 16 (the linear algebra)",
            ),
            ("the PointNet++ autoencoder", dict(architecture="pointnet2", refined=None), "Appendix, Fig. 17"),
        )
    ),
    Claim(
        "pointnet-without-transformer-better",
        "The PointNet autoencoder without spatial transformers reconstructs better than with them (so the "
        "comparisons use it)",
        dict(architecture="pointnet", refined=None),
        dict(architecture="pointnet_stn", refined=None),
        "Section 7 (the PointNet baseline)",
    ),
    Claim(
        "ours-below-paper",
        "Our variant reconstructs better than the paper's network on the same input",
        dict(_INT_EXT, variant="ours"),
        _INT_EXT,
        "docs/results.md, 'Our variant'",
        ours=True,
    ),
    Claim(
        "more-bodies-unseen",
        "Training our variant with a body per shape lowers its error on unseen bodies",
        dict(_INT_EXT, variant="ours", bodies="shape", group="bodies-shape"),
        dict(_INT_EXT, variant="ours"),
        "docs/results.md, 'Generalisation'",
        where=dict(split="test_subjects"),
        ours=True,
    ),
    Claim(
        "comp-5k-target",
        "Trained on exact, 5k-mapped and 2k-mapped operators, the Ext network meets the 5k target: test shapes given "
        "on 5k meshes, through computed maps, within 3× of the paper's network's error on their exact 1k operators",
        PAPER_ROWS["OperatorNet (Comp)(Ext)"] | dict(group="comp-three", resolution="5k", maps="computed"),
        dict(_INT_EXT, resolution="1k", maps="exact"),
        "docs/results.md, 'Generalisation'",
        table="discretisation",
        factor=3.0,
        ours=True,
    ),
)


def judge(claim: Claim | str, rows) -> Judged:
    """``claim`` (a :class:`Claim`, or the key of one of :data:`CLAIMS`) measured on ``rows`` (see the module's
    docstring).
    """
    from .stats import compare

    if isinstance(claim, str):
        known = {c.key: c for c in CLAIMS}
        if claim not in known:
            raise ValueError(f"unknown claim {claim!r}; the claims are {sorted(known)}.")
        claim = known[claim]
    if not isinstance(claim, Claim):
        raise ValueError(f"claim must be a Claim or the key of one of CLAIMS, got {claim!r}.")
    rows = as_rows(rows)
    mine = [r for r in rows if r.get("table") == claim.table and matches(r, **claim.where)]
    found = [[r for r in mine if matches(r, **fields)] for fields in (claim.better, claim.worse)]
    if any(not f or f[0].get(claim.metric) is None for f in found):
        return Judged(claim, "inconclusive", missing=True)
    if any(len(f) > 1 for f in found):  # several rows stand for one method (merged calls): none is judged
        return Judged(claim, "inconclusive")
    (b,), (w,) = found
    means = dict(better_mean=b[claim.metric], worse_mean=w[claim.metric])
    if f"{claim.metric}_shapes" not in b or f"{claim.metric}_shapes" not in w:
        return Judged(claim, "inconclusive", **means)
    split = claim.where.get("split")
    where = {k: v for k, v in claim.where.items() if k != "split"}
    try:
        c = compare(
            mine,
            dict(claim.better, **where),
            dict(claim.worse, **where),
            metric=claim.metric,
            split=split,
            factor=claim.factor,
        )
    except ValueError:  # rows that cannot be paired (other seeds, NaN errors): measured, not judged
        return Judged(claim, "inconclusive", **means)
    verdict = {"a better": "confirmed", "b better": "refuted"}.get(c.verdict, "inconclusive")
    means = dict(better_mean=c.a_mean, worse_mean=c.b_mean / claim.factor)  # on the shapes the two share
    return Judged(claim, verdict, comparison=c, **means)


def judge_all(rows, claims=CLAIMS) -> list[Judged]:
    """Every claim measured on ``rows``, those whose rows are all there."""
    rows = as_rows(rows)
    return [j for j in (judge(c, rows) for c in claims) if not j.missing]


def _paired_on(d) -> str:
    """What a difference was paired on: ``"3 seeds × 50 shapes"``, ``"1 seed, 12 shapes"``."""
    seeds = len(d.per_seed)
    return f"{seeds} seeds × {d.n_shapes} shapes" if seeds > 1 else f"1 seed, {d.n_shapes} shapes"


def claims_markdown(rows, claims=CLAIMS) -> list[str]:
    """The claims table (lines): each claim, its source, the two means, the paired difference with its interval and
    the verdict; empty when no claim's rows are there.
    """
    judged = judge_all(rows, claims)
    if not judged:
        return []
    lines = [
        "Each claim is judged by a paired comparison of its two methods on the same test shapes, seed by seed "
        "(`opnet.experiments.claims`): *confirmed* or *refuted* when the 95 % interval of the difference lies on one "
        "side of 0, else *inconclusive*. Rows without per-shape errors (one training, its means alone) are "
        "*inconclusive*: the means are shown, the interval is not known.",
        "",
        "| claim | source | the paper | ours: better / worse | difference (95 % interval) | verdict |",
        "|---|---|---|---|---|---|",
    ]
    for j in judged:
        c, scale = j.claim, 1e4 if j.claim.metric == "d_R" else 1.0
        d = None if j.comparison is None else j.comparison.difference
        diff = "–" if d is None else f"{d.text(scale)} ({_paired_on(d)})"  # the means too: on the shapes paired
        if j.better_mean is None:
            means, holds = "several rows", ""
        else:
            times = "" if c.factor == 1 else f"{c.factor:g} × "
            means = f"{number_text(j.better_mean, scale)} / {times}{number_text(j.worse_mean, scale)}"
            measured = math.isfinite(j.better_mean) and math.isfinite(j.worse_mean)  # NaN: e.g. every path stuck
            worse = j.better_mean >= c.factor * j.worse_mean
            holds = (
                "" if j.comparison is not None or not measured else (" (means: not)" if worse else " (means: holds)")
            )
        who = f"{c.statement}{' (ours)' if c.ours else ''}"
        lines.append(f"| {who} | {c.source} | {c.paper or '–'} | {means} | {diff} | **{j.verdict}**{holds} |")
    unit = "d_R ×10⁻⁴ m²; smoothness: the largest step over the path length."
    return lines + ["", unit]
