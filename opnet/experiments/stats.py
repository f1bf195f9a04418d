"""Intervals over seeds and test shapes, and paired comparisons with a verdict.

A measurement of a method is a ``(seeds, shapes)`` array: one error per test shape for each training seed (the same
shapes for every seed). Its interval is a two-level bootstrap: each resample draws the seeds with replacement, then
the shapes with replacement (the same shapes for every drawn seed), and takes the mean; the interval is the
central ``level`` of those means (percentiles). It so carries both sources of spread: another training, and other
test shapes. With one seed it is the bootstrap over shapes alone, and says nothing of another training.

A comparison of two methods is paired: the same test shapes, seed by seed (seed ``s`` of one beside seed ``s`` of the
other), so the shapes' own difficulty cancels. Its verdict is ``"a better"`` or ``"b better"`` when the interval of
the mean difference excludes 0 (errors: lower is better), else ``"no difference shown"``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "LEVEL",
    "BOOTSTRAP",
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
#: Bootstrap resamples.
BOOTSTRAP = 2000
#: The verdicts of a comparison of errors (lower is better).
VERDICTS = ("a better", "b better", "no difference shown")


@dataclass(frozen=True)
class Interval:
    """The mean of a ``(seeds, shapes)`` measurement, its spread and its interval.

    ``per_seed``: each seed's mean over the shapes; ``std``: their standard deviation (``ddof=1``; 0 for one seed);
    ``low``, ``high``: the bootstrap interval of the mean (see the module's docstring); ``half_width``: half its width.
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


def _bootstrap_means(x: np.ndarray, n_boot: int, rng: np.random.Generator) -> np.ndarray:
    """Means of ``n_boot`` two-level resamples of ``x`` ``(S, N)``: seeds, then shapes, with replacement."""
    S, N = x.shape
    seeds = rng.integers(0, S, (n_boot, S))
    shapes = rng.integers(0, N, (n_boot, N))
    out = np.empty(n_boot)
    for start in range(0, n_boot, 256):  # in blocks: (block, S, N) at a time
        sl = slice(start, start + 256)
        drawn = x[:, shapes[sl]]  # (S, block, N): every seed on each resample's shapes
        per_seed = drawn.mean(axis=2).T  # (block, S)
        out[sl] = np.take_along_axis(per_seed, seeds[sl], axis=1).mean(axis=1)  # the drawn seeds' mean
    return out


def interval(values, *, level: float = LEVEL, n_boot: int = BOOTSTRAP, seed: int = 0) -> Interval:
    """The :class:`Interval` of a ``(seeds, shapes)`` measurement (a 1-d array: one seed)."""
    if not 0 < level < 1:
        raise ValueError(f"level must be between 0 and 1 (e.g. 0.95), got {level!r}.")
    x = _as_measure(values)
    means = _bootstrap_means(x, n_boot, np.random.default_rng(seed))
    low, high = np.quantile(means, [(1 - level) / 2, (1 + level) / 2])
    per_seed = x.mean(axis=1)
    std = float(per_seed.std(ddof=1)) if len(per_seed) > 1 else 0.0
    return Interval(float(x.mean()), std, float(low), float(high), tuple(map(float, per_seed)), x.shape[1], level)


def paired_difference(
    a, b, *, names=("a", "b"), level: float = LEVEL, n_boot: int = BOOTSTRAP, seed: int = 0
) -> Comparison:
    """The paired comparison of two ``(seeds, shapes)`` measurements of errors on the same shapes (seed ``s`` of
    ``a`` beside seed ``s`` of ``b``): the interval of the mean of ``a − b`` and the verdict (:data:`VERDICTS`).
    """
    x, y = _as_measure(a, "a"), _as_measure(b, "b")
    if x.shape != y.shape:
        raise ValueError(
            f"a paired comparison needs the same seeds and shapes on both sides, got {x.shape} and {y.shape}: "
            "evaluate both on the same test set, with as many seeds."
        )
    d = interval(x - y, level=level, n_boot=n_boot, seed=seed)
    verdict = VERDICTS[0] if d.high < 0 else VERDICTS[1] if d.low > 0 else VERDICTS[2]
    return Comparison(names[0], names[1], d, verdict)


#: The errors a row summarises over seeds (each with its ``<metric>_shapes``: per seed, per shape).
METRICS = ("d_R", "d_V", "d_E")


def summarize_seeds(rows: list[dict], *, level: float = LEVEL) -> dict:
    """One row from the rows of one method on one test set, one per training seed (each with per-shape errors,
    ``opnet.evaluate.evaluate(..., per_shape=True)``, on the same shapes): the first's fields, and for each of
    :data:`METRICS` the mean over seeds and shapes, its ``_std`` over seeds, its interval ``_low`` / ``_high``
    (:func:`interval`), each seed's mean ``_seeds`` and the per-seed, per-shape errors ``_shapes``; ``seeds`` lists
    the seeds, ``runs`` their runs, ``train_seconds`` their sum.
    """
    if not rows:
        raise ValueError("summarize_seeds needs the rows of at least one seed.")
    shapes = [r.get("shapes") for r in rows]
    if any(s is None for s in shapes) or any(s != shapes[0] for s in shapes):
        raise ValueError(
            "each seed's row needs its per-shape errors on the same shapes: evaluate(..., per_shape=True)."
        )
    out = dict(rows[0])
    for metric in METRICS:
        values = np.array([r[f"{metric}_shapes"] for r in rows], dtype=np.float64)
        finite = np.isfinite(values).all()  # d_V of an open mesh is NaN: no interval
        iv = interval(values, level=level) if finite else None
        out[metric] = float(np.mean(values)) if finite else float("nan")
        out[f"{metric}_median"] = float(np.median(values)) if finite else float("nan")
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
    if values is None:
        raise ValueError(
            f"the row of {row.get('method')!r} has no per-shape {metric}: evaluate with per_shape=True "
            "(opnet.ablation's rows have them)."
        )
    return np.atleast_2d(np.asarray(values, dtype=np.float64))


def compare(rows, a: dict, b: dict, *, metric: str = "d_R", split: str = "test", level: float = LEVEL) -> Comparison:
    """The paired comparison (:func:`paired_difference`) of the method whose rows have the fields ``a`` against the
    one with ``b`` (:func:`opnet.experiments.rows.matches`), on ``split``: the same shapes, seed by seed (a
    deterministic method of one row, a baseline, stands beside each seed of the other). The verdict says which has the
    lower ``metric``.
    """
    from .rows import matches

    def find(fields):
        found = [r for r in rows if r.get("split") == split and matches(r, **fields)]
        if len(found) != 1:
            raise ValueError(
                f"{len(found)} rows on {split!r} have the fields {fields}; give fields that single out one method's "
                "row."
            )
        return found[0]

    ra, rb = find(a), find(b)
    if ra.get("shapes") != rb.get("shapes"):
        raise ValueError("the two rows were measured on other shapes; compare rows of one collection and test set.")
    x, y = _errors(ra, metric), _errors(rb, metric)
    if len(x) != len(y) and 1 in (len(x), len(y)):  # a deterministic method beside every seed of the other
        x, y = np.broadcast_arrays(x, y)
    return paired_difference(x, y, names=(ra.get("method"), rb.get("method")), level=level)
