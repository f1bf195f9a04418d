"""Has a training converged? A measure on its history: how far the validation error of its last epochs is from the
best one.

A run whose validation curve still falls at its end, or still jumps by tens of per cent between epochs, has a best
epoch that is partly luck: training it again with another seed, or a few more epochs, moves the result. The measure
here is the one the reproduction states (docs/results.md, "Training that converges"): the last ``tail`` of the
epochs (10 % by default) all lie within ``tolerance`` (5 %) of the best validation ``d_R`` of the run.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

__all__ = ["Convergence", "convergence", "TAIL", "TOLERANCE"]

#: The share of the last epochs the measure looks at.
TAIL = 0.1
#: How far above the best validation d_R those epochs may lie (a fraction of it).
TOLERANCE = 0.05


@dataclass(frozen=True)
class Convergence:
    """The measure of one history (:func:`convergence`).

    Attributes
    ----------
    best_epoch : int
        The epoch of the lowest validation ``d_R``.
    best_val : float
        That ``d_R`` (length², e.g. m²).
    tail_epochs : int
        How many of the last epochs were looked at.
    tail_ratio : float
        The worst of their ``d_R`` over ``best_val`` (1: the tail holds the best and nothing worse).
    converged : bool
        ``tail_ratio <= 1 + tolerance``.
    """

    best_epoch: int
    best_val: float
    tail_epochs: int
    tail_ratio: float
    converged: bool

    def as_dict(self) -> dict:
        """The fields, as a dict (what a row's ``convergence`` holds)."""
        return asdict(self)


def convergence(history, *, tail: float = TAIL, tolerance: float = TOLERANCE) -> Convergence:
    """Whether a run's validation curve has flattened: its last ``tail`` of epochs (at least one) all within
    ``tolerance`` of the best validation ``d_R``.

    Parameters
    ----------
    history : list of dict
        One record per epoch with ``val_d_R`` (what :func:`opnet.train.fit` returns, or ``read_history``).
    tail : float
        The share of the last epochs looked at, in (0, 1].
    tolerance : float
        How far above the best they may lie, as a fraction of it (>= 0).

    Returns
    -------
    Convergence
    """
    if not (isinstance(tail, (int, float)) and 0 < tail <= 1):
        raise ValueError(f"tail must be a share of the epochs in (0, 1], e.g. 0.1, got {tail!r}.")
    if not (isinstance(tolerance, (int, float)) and tolerance >= 0):
        raise ValueError(f"tolerance must be a fraction >= 0 of the best d_R, e.g. 0.05, got {tolerance!r}.")
    vals = [float(h["val_d_R"]) for h in history]
    if not vals:
        raise ValueError("the history is empty: train at least one epoch.")
    if not all(math.isfinite(v) for v in vals):
        raise ValueError("the history holds a NaN or infinite val_d_R: the run diverged; it has not converged.")
    best = min(range(len(vals)), key=vals.__getitem__)
    n_tail = max(1, math.ceil(tail * len(vals) - 1e-9))
    ratio = max(vals[-n_tail:]) / vals[best] if vals[best] > 0 else 1.0
    return Convergence(
        best_epoch=int(history[best].get("epoch", best + 1)),
        best_val=vals[best],
        tail_epochs=n_tail,
        tail_ratio=float(ratio),
        converged=bool(ratio <= 1 + tolerance),
    )
