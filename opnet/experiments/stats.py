"""Intervals over seeds and test shapes, and paired comparisons with a verdict.

A measurement of a method is a ``(seeds, shapes)`` array: one error per test shape for each training seed (the same
shapes for every seed). Its interval holds both sources of spread, another training and other test shapes: the mean
± ``q · se``, with ``se² = var(seed means) / S + var(shape means) / N`` (the seeds' means over the shapes, the shapes'
means over the seeds; a little conservative, as the seed-by-shape noise counts in both) and ``q`` Student's
quantile with ``S − 1`` degrees of freedom (so that three seeds give a wide interval, as they should), the normal one
for a single seed, whose interval then holds the shapes alone and says nothing of another training. Shapes are
taken as independent; held-out sequences of one subject are not quite, so the interval is if anything narrow.

A comparison of two methods is paired: the same test shapes, seed by seed (seed ``s`` of one beside seed ``s`` of the
other), so the shapes' own difficulty cancels. Its verdict is ``"a better"`` or ``"b better"`` when the interval of
the mean difference excludes 0 (errors: lower is better), else ``"no difference shown"``; a trained method of one
seed is never called better (one training cannot tell another training's spread).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = [
    "LEVEL",
    "METRICS",
    "VERDICTS",
    "Interval",
    "Comparison",
    "interval",
    "paired_difference",
    "summarize_seeds",
    "compare",
]

#: The interval's coverage.
LEVEL = 0.95
#: The verdicts of a comparison of errors (lower is better).
VERDICTS = ("a better", "b better", "no difference shown")


@dataclass(frozen=True)
class Interval:
    """The mean of a ``(seeds, shapes)`` measurement, its spread and its interval.

    ``per_seed``: each seed's mean over the shapes; ``std``: their standard deviation (``ddof=1``; 0 for one seed);
    ``low``, ``high``: the interval of the mean (see the module's docstring); ``half_width``: half its width.
    """

    mean: float
    std: float
    low: float
    high: float
    per_seed: tuple
    n_shapes: int
    level: float = LEVEL

    @property
    def half_width(self) -> float:
        return (self.high - self.low) / 2

    def text(self, scale: float = 1.0, digits: int = 3) -> str:
        """``mean ± half-width`` (both × ``scale``), as tables print it."""
        return f"{scale * self.mean:.{digits}g} ± {scale * self.half_width:.2g}"


@dataclass(frozen=True)
class Comparison:
    """A paired comparison of ``a`` against ``b``: the mean of ``a − b`` (its :class:`Interval`) and the verdict."""

    a: str
    b: str
    difference: Interval
    verdict: str
    a_mean: float | None = None
    b_mean: float | None = None

    def text(self, scale: float = 1.0) -> str:
        d = self.difference
        return f"{self.a} − {self.b} = {d.text(scale)} ({d.level:.0%} interval): {self.verdict}"


def _as_measure(values, name: str = "values") -> np.ndarray:
    x = np.asarray(values, dtype=np.float64)
    if x.ndim == 1:
        x = x[None]
    if x.ndim != 2 or x.shape[0] < 1 or x.shape[1] < 1:
        raise ValueError(f"{name} must be (seeds, shapes) with at least one of each, got shape {np.shape(values)}.")
    if not np.isfinite(x).all():
        raise ValueError(f"{name} holds NaN or infinite errors; give finite per-shape values.")
    return x


def interval(values, *, level: float = LEVEL) -> Interval:
    """The :class:`Interval` of a ``(seeds, shapes)`` measurement (a 1-d array: one seed), as the module says."""
    from scipy import stats as scipy_stats

    if not 0 < level < 1:
        raise ValueError(f"level must be between 0 and 1 (e.g. 0.95), got {level!r}.")
    x = _as_measure(values)
    S, N = x.shape
    per_seed, per_shape = x.mean(axis=1), x.mean(axis=0)
    se2 = (per_seed.var(ddof=1) / S if S > 1 else 0.0) + (per_shape.var(ddof=1) / N if N > 1 else 0.0)
    q = scipy_stats.t.ppf((1 + level) / 2, S - 1) if S > 1 else scipy_stats.norm.ppf((1 + level) / 2)
    mean, half = float(x.mean()), float(q * np.sqrt(se2))
    std = float(per_seed.std(ddof=1)) if S > 1 else 0.0
    return Interval(mean, std, mean - half, mean + half, tuple(map(float, per_seed)), N, level)


def paired_difference(a, b, *, names=("a", "b"), level: float = LEVEL, verdict: bool = True) -> Comparison:
    """The paired comparison of two ``(seeds, shapes)`` measurements of errors on the same shapes (seed ``s`` of
    ``a`` beside seed ``s`` of ``b``): the interval of the mean of ``a − b`` and the verdict (:data:`VERDICTS`;
    ``verdict=False``: always ``"no difference shown"``, for a comparison that cannot tell).
    """
    x, y = _as_measure(a, "a"), _as_measure(b, "b")
    if x.shape != y.shape:
        raise ValueError(
            f"a paired comparison needs the same seeds and shapes on both sides, got {x.shape} and {y.shape}: "
            "evaluate both on the same test set, with as many seeds."
        )
    d = interval(x - y, level=level)
    said = VERDICTS[2] if not verdict else VERDICTS[0] if d.high < 0 else VERDICTS[1] if d.low > 0 else VERDICTS[2]
    return Comparison(names[0], names[1], d, said, float(x.mean()), float(y.mean()))


#: The errors a row summarises over seeds (each with its ``<metric>_shapes``: per seed, per shape).
METRICS = ("d_R", "d_V", "d_E")


def summarize_seeds(rows: list[dict], *, level: float = LEVEL, metrics=METRICS) -> dict:
    """One row from the rows of one method on one test set, one per training seed (each with per-shape errors,
    ``opnet.evaluate.evaluate(..., per_shape=True)``, on the same shapes): the first's fields, and for each of
    ``metrics`` (default :data:`METRICS`; the applications' rows have others, e.g. ``smoothness``) the mean over seeds
    and shapes, its ``_std`` over seeds, its interval ``_low`` / ``_high`` (:func:`interval`), each seed's mean
    ``_seeds`` and the per-seed, per-shape errors ``_shapes``; ``seeds`` lists the seeds, ``runs`` their runs,
    ``train_seconds`` their sum.
    """
    if not rows:
        raise ValueError("summarize_seeds needs the rows of at least one seed.")
    shapes = [r.get("shapes") for r in rows]
    if any(s is None for s in shapes) or any(s != shapes[0] for s in shapes):
        raise ValueError(
            "each seed's row needs its per-shape errors on the same shapes: evaluate(..., per_shape=True)."
        )
    out = dict(rows[0])
    for metric in metrics:
        values = np.array([r[f"{metric}_shapes"] for r in rows], dtype=np.float64)
        finite = np.isfinite(values).all()  # d_V of an open mesh is NaN: no interval
        iv = interval(values, level=level) if finite else None
        # not finite (d_V of an open mesh, a path that does not move): over the finite values, and no interval
        some = np.isfinite(values).any()
        out[metric] = float(np.mean(values) if finite else np.nanmean(values) if some else np.nan)
        out[f"{metric}_median"] = float(np.median(values) if finite else np.nanmedian(values) if some else np.nan)
        out |= {f"{metric}_std": None, f"{metric}_low": None, f"{metric}_high": None, f"{metric}_seeds": None}
        if iv is not None:
            out |= {f"{metric}_std": iv.std, f"{metric}_low": iv.low, f"{metric}_high": iv.high}
            out[f"{metric}_seeds"] = list(iv.per_seed)
        out[f"{metric}_shapes"] = values.tolist()
    out["seeds"] = [r.get("seed") for r in rows]
    out.pop("seed", None)  # the row is every seed's
    out["runs"] = [r.get("run") for r in rows]
    out["run"] = "+".join(str(r.get("run")) for r in rows) if len(rows) > 1 else rows[0].get("run")
    if all(r.get("train_seconds") is not None for r in rows):
        out["train_seconds"] = round(sum(r["train_seconds"] for r in rows), 1)
    return out


def _errors(row: dict, metric: str) -> np.ndarray:
    values = row.get(f"{metric}_shapes")
    if not isinstance(values, list) and metric not in METRICS:
        held = sorted(k[: -len("_shapes")] for k, v in row.items() if k.endswith("_shapes") and isinstance(v, list))
        raise ValueError(
            f"metric {metric!r} is not one of the row's per-shape metrics ({', '.join(held) or 'none'}); "
            "e.g. metric='d_R'."
        )
    if values is None:
        raise ValueError(
            f"the row of {row.get('method')!r} has no per-shape {metric}: evaluate with per_shape=True "
            "(opnet.ablation's rows have them)."
        )
    return np.atleast_2d(np.asarray(values, dtype=np.float64))


def _shared_shapes(a, b) -> list:
    """The shapes (indices) of ``a`` also in ``b``, in ``a``'s order, when one row's shapes are a subset of the
    other's (a slow baseline measured on a few of a network's test shapes); an error otherwise.
    """
    if not (isinstance(a, list) and isinstance(b, list)) or not (set(a) <= set(b) or set(b) <= set(a)):
        raise ValueError(
            "the two rows were measured on other shapes (neither's are a subset of the other's); compare rows of one "
            "collection and test set."
        )
    shared = [i for i in a if i in set(b)]
    if not shared:
        raise ValueError("the two rows share no shape; compare rows of one collection and test set.")
    return shared


def _fields(name: str, value) -> dict:
    """``compare``'s ``a`` or ``b`` as fields: a dict as it is, a string as a method's name."""
    if isinstance(value, str):
        return {"method": value}
    if isinstance(value, Mapping):
        return dict(value)
    raise ValueError(
        f"{name} must be the fields of one method's rows (a dict, e.g. {{'entry': 'int+ext'}}) or its method name, "
        f"got {value!r}."
    )


def compare(
    rows, a: dict, b: dict, *, metric: str = "d_R", split: str = "test", level: float = LEVEL, factor: float = 1.0
) -> Comparison:
    """The paired comparison (:func:`paired_difference`) of the method whose rows have the fields ``a`` against the
    one with ``b`` (:func:`opnet.experiments.rows.matches`; a string: the ``method`` field), on ``split``: the same
    shapes (those both rows measured, when one row measured a few of them: a slow baseline), seed by seed (a
    deterministic method of one row, a baseline, stands beside each seed of the other). The verdict says which has
    the lower ``metric``. ``factor``: compare ``a`` with ``factor`` times ``b`` (the
    difference ``a − factor·b``), for a claim such as "within 5× of" (``factor=5``) or "ten times better than"
    (``factor=0.1``).
    """
    if not (isinstance(factor, (int, float)) and not isinstance(factor, bool) and factor > 0):
        raise ValueError(f"factor must be a number > 0 (1: a plain comparison), got {factor!r}.")
    from .rows import as_rows, matches

    rows = as_rows(rows)
    a, b = _fields("a", a), _fields("b", b)

    def find(fields):
        found = [r for r in rows if r.get("split") == split and matches(r, **fields)]
        if len(found) != 1:
            raise ValueError(
                f"{len(found)} rows on {split!r} have the fields {fields}; give fields that single out one method's "
                "row."
            )
        return found[0]

    ra, rb = find(a), find(b)
    x, y = _errors(ra, metric), _errors(rb, metric)
    if ra.get("shapes") != rb.get("shapes"):  # one measured on a few of the other's shapes: paired on those
        shared = _shared_shapes(ra.get("shapes"), rb.get("shapes"))
        x, y = x[:, [ra["shapes"].index(i) for i in shared]], y[:, [rb["shapes"].index(i) for i in shared]]
    trained = [r for r, v in ((ra, x), (rb, y)) if r.get("baseline") is None]
    if len(x) != len(y):
        fixed = [r for r, v in ((ra, x), (rb, y)) if len(v) == 1 and r.get("baseline") is not None]
        if not fixed:
            raise ValueError(f"the rows hold {len(x)} and {len(y)} seeds: compare rows trained with the same seeds.")
        x, y = np.broadcast_arrays(x, y)  # a baseline (deterministic) beside every seed of the other
    elif len(trained) == 2 and ra.get("seeds") != rb.get("seeds"):
        raise ValueError(f"the rows' seeds differ ({ra.get('seeds')} and {rb.get('seeds')}): pair them seed by seed.")
    enough = all(len(_errors(r, metric)) > 1 for r in trained)  # one training cannot tell another's spread
    names = (ra.get("method"), rb.get("method") if factor == 1 else f"{factor:g} × {rb.get('method')}")
    return paired_difference(x, factor * y, names=names, level=level, verdict=enough)
