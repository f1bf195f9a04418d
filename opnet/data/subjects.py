"""Subjects of the body models: phenotype vectors (numpy only), shared by humans, heads and hands.

A subject is a vector of 6 values in [0, 1], one per phenotype of the anny body model (:data:`PHENOTYPES`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["PHENOTYPES", "AVERAGE_SUBJECT", "random_subjects", "check_subjects"]

#: Order of the columns of a subject vector; each value lies in [0, 1]. ``gender`` 0 is male and
#: 1 female; ``age`` is anny's age axis (0.67 ≈ 16 years, 0.77 ≈ 18, 0.83 ≈ 64, 1 ≈ 110).
PHENOTYPES = ("gender", "age", "muscle", "weight", "height", "proportions")

#: The base subject of the collections: an average adult of about 40 (anny age 0.8), 1.69 m tall.
#: (All-0.5 phenotypes would be an adolescent: anny's age 0.5 is about 13 years.)
AVERAGE_SUBJECT = (0.5, 0.8, 0.5, 0.5, 0.375, 0.5)

# Anny's age axis against age in years (anny's shape_calibration "morphological age" anchors).
_AGE_YEARS = (16.0, 18.0, 64.0, 110.0)
_AGE_ANNY = (0.67, 0.77, 0.83, 1.0)


def random_subjects(n: int, rng: np.random.Generator) -> np.ndarray:
    """Random adult subjects ``(n, 6)`` float64 in [0, 1], columns in :data:`PHENOTYPES` order.

    Gender uniform in [0, 1]; age uniform in 20-70 years; muscle and weight Beta(2, 2);
    height Beta(15, 25) (mean 0.375: about 1.76 m for men, 1.62 m for women, close to anny's
    calibration to WHO statistics); proportions uniform.
    """
    years = rng.uniform(20.0, 70.0, n)
    return np.stack(
        [
            rng.uniform(0.0, 1.0, n),
            np.interp(years, _AGE_YEARS, _AGE_ANNY),
            rng.beta(2.0, 2.0, n),
            rng.beta(2.0, 2.0, n),
            rng.beta(15.0, 25.0, n),
            rng.uniform(0.0, 1.0, n),
        ],
        axis=1,
    )


def check_subjects(subjects) -> np.ndarray:
    """``subjects`` as a float64 array ``(N, 6)``, or a ValueError naming the expected shape."""
    subjects = np.asarray(subjects, dtype=np.float64)
    if subjects.ndim != 2 or subjects.shape[1] != len(PHENOTYPES):
        raise ValueError(f"subjects must have shape (N, {len(PHENOTYPES)}), got {subjects.shape}.")
    return subjects
