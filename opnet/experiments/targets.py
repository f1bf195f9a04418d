"""The reproduction's targets as records: what is measured (the fields of the numerator's and the denominator's rows,
the metric, where), the threshold and its direction, and where the target comes from; :func:`judge` measures one on
rows.

A target is a ratio of two rows' metric (``denominator`` given) or one row's metric itself. The rows are found by
their structured fields (:func:`opnet.experiments.report.matches`), never by a display name; a numerator that
matches several rows (each network of a table, say) gives a verdict for each.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .paper import PAPER_TABLE1
from .plan import PAPER_ROWS
from .rows import matches

__all__ = ["Target", "Verdict", "TARGETS", "judge", "targets_of"]

_PAPER = PAPER_ROWS["OperatorNet (Int+Ext)"]  # the paper's network, on the three operators: the reference
_OURS = dict(_PAPER, variant="ours")  # this project's variant on the same input
_NN = PAPER_ROWS["Nearest neighbour (Int+Ext)"]
_PROJECT = "this project's target at `default` (docs/results.md)"


@dataclass(frozen=True)
class Target:
    """One target (see the module's docstring).

    Parameters
    ----------
    key : stable identity.
    label : what is measured, as shown (``"NN's d_R / OperatorNet (Int+Ext)'s"``).
    numerator, denominator : the fields of the rows whose metric is divided (``denominator`` ``None``: the
        numerator's metric is the measure).
    where : fields both rows share (``split``, or an application's ``kind``).
    table : the rows' ``table``.
    metric : ``"d_R"``, ``"d_V"``, ``"d_E"``...
    threshold, at_least : met when the measure is ``>= threshold`` (``at_least``) or ``<= threshold``.
    source : where the target comes from.
    paper : the paper's own value of the measure (``None``: the paper gives none).
    """

    key: str
    label: str
    numerator: dict = field(hash=False)
    threshold: float
    at_least: bool
    source: str
    denominator: dict | None = field(default=None, hash=False)
    where: dict = field(default_factory=dict, hash=False)
    table: str = "table1"
    metric: str = "d_R"
    paper: float | None = None


@dataclass(frozen=True)
class Verdict:
    """A target measured on rows: its numerator's row (and value), the denominator's value, the measure, and ``met``."""

    target: Target
    row: dict
    numerator: float
    denominator: float | None
    value: float
    met: bool


def _ratio(name: str) -> float:
    return PAPER_TABLE1[name][0] / PAPER_TABLE1["OperatorNet (Int+Ext)"][0]


#: The targets of the reproduction's report (``results.md``'s "Targets" and each section's own).
TARGETS = (
    *(
        Target(
            f"nn-ratio-{split}",
            "NN's d_R / OperatorNet (Int+Ext)'s",
            _NN,
            10.0,
            True,
            _PROJECT,
            denominator=_PAPER,
            where=dict(split=split),
            paper=_ratio("Nearest neighbour (Int+Ext)"),
        )
        for split in ("test", "test_subjects", "unseen_species", "eval_subset")
    ),
    *(  # the paper's network's own d_V and d_E on test: at most the paper's
        Target(
            metric,
            f"OperatorNet (Int+Ext)'s {metric}",
            _PAPER,
            PAPER_TABLE1["OperatorNet (Int+Ext)"][column],
            False,
            "the paper's Table 1",
            where=dict(split="test"),
            metric=metric,
            paper=PAPER_TABLE1["OperatorNet (Int+Ext)"][column],
        )
        for column, metric in ((1, "d_V"), (2, "d_E"))
    ),
    Target(
        "ours-gain",
        "OperatorNet (Int+Ext)'s d_R / ours",
        _PAPER,
        1.5,
        True,
        _PROJECT,
        denominator=_OURS,
        where=dict(split="test"),
    ),
    *(
        Target(
            f"comp-{short}",
            f"{name}'s d_R / OperatorNet (Int+Ext)'s (ground-truth maps)",
            PAPER_ROWS[name],
            5.0,
            False,
            _PROJECT,
            denominator=_PAPER,
            where=dict(split="test"),
            paper=_ratio(name),
        )
        for short, name in (("int+ext", "OperatorNet (Comp)(Int+Ext)"), ("ext", "OperatorNet (Comp)(Ext)"))
    ),
    Target(
        "discretisation-5k",
        "5k → 1k through computed maps",
        dict(resolution="5k", maps="computed", labels=None),  # the networks decoding to the 1k mesh
        3.0,
        False,
        _PROJECT,
        denominator=dict(_PAPER, resolution="1k", maps="exact"),
        table="discretisation",
    ),
    *(
        Target(
            f"analogy-{kind}-{other}",
            f"{who} / OperatorNet",
            fields,
            1.0,
            True,
            "this project's target at `default`: OperatorNet (mult.) beats PointNet and NN (the paper's Figs. 9-10)",
            denominator=dict(_PAPER, scheme="multiplicative"),
            where=dict(kind=kind),
            table="analogy",
        )
        for kind in ("pose", "body")
        for other, who, fields in (
            ("pointnet", "PointNet AE", dict(architecture="pointnet", refined=None)),
            ("nn", "Nearest neighbour", dict(baseline="nearest_neighbour")),
        )
    ),
)


def targets_of(table: str) -> list[Target]:
    """The targets on the rows of ``table``."""
    return [t for t in TARGETS if t.table == table]


def judge(target: Target, rows) -> list[Verdict]:
    """``target`` measured on ``rows``: a verdict per row matching its numerator (and ``where``), divided by the first
    row matching its denominator; ``[]`` where a row is missing or a value is not finite.
    """
    import math

    mine = [r for r in rows if r.get("table") == target.table and matches(r, **target.where)]
    den = None
    if target.denominator is not None:
        ref = next((r for r in mine if matches(r, **target.denominator)), None)
        den = None if ref is None else ref.get(target.metric)
        if den is None or not math.isfinite(den) or den == 0:
            return []
    out = []
    for r in mine:
        num = r.get(target.metric)
        if not matches(r, **target.numerator) or num is None or not math.isfinite(num):
            continue
        value = num if den is None else num / den
        met = value >= target.threshold if target.at_least else value <= target.threshold
        out.append(Verdict(target, r, num, den, value, met))
    return out
