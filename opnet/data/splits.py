"""Splits like the paper's (held-out sub-collections, unseen subjects) and its 50-shape evaluation subset."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..mesh import farthest_first

__all__ = ["make_splits", "hausdorff", "furthest_point_subset"]


def make_splits(
    subjects: np.ndarray,
    groups: np.ndarray,
    rng: np.random.Generator,
    *,
    n_test_subcollections: int = 10,
    n_test_subjects: int = 1,
    n_val_subcollections: int = 3,
    held_out_groups=None,
    unseen=(),
) -> np.ndarray:
    """Split labels ``(N,)``: ``"train"``, ``"val"``, ``"test"`` and ``"test_subjects"``.

    A sub-collection is a (subject, group) pair, e.g. one person performing one action.
    ``test_subjects`` holds every shape of ``n_test_subjects`` subjects; ``test`` holds
    ``n_test_subcollections`` whole sub-collections of the remaining subjects (as the paper
    holds out 10 DFAUST sequences); ``val`` holds ``n_val_subcollections`` more, for model
    selection. Groups listed in ``held_out_groups`` (e.g. random poses) are never held out. Subjects listed in
    ``unseen`` are held out as well, before the ``n_test_subjects`` drawn among the others (an animal species that
    training never sees).
    """
    subjects, groups = np.asarray(subjects), np.asarray(groups)
    uniq = np.unique(subjects)
    unseen = list(unseen)
    unknown = [u for u in unseen if u not in set(uniq.tolist())]  # compared as Python values: no string truncated
    if unknown:
        raise ValueError(f"unseen subjects {sorted(unknown, key=str)} are not among the subjects.")
    unseen = uniq[[u in set(unseen) for u in uniq.tolist()]]
    others = np.setdiff1d(uniq, unseen)
    if n_test_subjects >= len(others):
        raise ValueError(
            f"{len(uniq)} subjects cannot leave {n_test_subjects + len(unseen)} unseen subjects and still train."
        )
    split = np.full(len(subjects), "train", dtype=object)
    unseen = np.r_[unseen, rng.choice(others, n_test_subjects, replace=False)]
    split[np.isin(subjects, unseen)] = "test_subjects"
    keep = set(held_out_groups or ())
    candidates = sorted({(s, g) for s, g in zip(subjects[split == "train"], groups[split == "train"]) if g not in keep})
    needed = n_test_subcollections + n_val_subcollections
    if needed > len(candidates) - 1:
        raise ValueError(f"only {len(candidates)} sub-collections to hold {needed} out of; use a larger preset.")
    picked = rng.choice(len(candidates), needed, replace=False)
    for rank, c in enumerate(picked):
        s, g = candidates[c]
        split[(subjects == s) & (groups == g)] = "test" if rank < n_test_subcollections else "val"
    return split.astype(str)


def hausdorff(X: np.ndarray, Y: np.ndarray) -> float:
    """Symmetric Hausdorff distance between point sets ``(n, 3)`` and ``(m, 3)`` (length unit of the input)."""
    return float(max(cKDTree(Y).query(X)[0].max(), cKDTree(X).query(Y)[0].max()))


def furthest_point_subset(vertices: np.ndarray, n: int) -> np.ndarray:
    """Indices of up to ``n`` distinct shapes ``(N, n_vertices, 3)``, by furthest-point sampling on Hausdorff distance.

    Starts from shape 0 and repeatedly adds the shape furthest (in Hausdorff distance)
    from those already chosen; needs ``n · N`` distances, not the ``N²`` matrix.
    """
    return farthest_first(lambda i: np.array([hausdorff(vertices[i], v) for v in vertices]), n)
