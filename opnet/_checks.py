"""Argument checks shared by the public entry points (numpy only, no torch).

Every message names the argument, what it got and what to do, so that bad input is answered at the call the
user made rather than deep inside numpy, scipy or torch. The checks are O(size) and run once per call.
"""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np

__all__ = ["is_integer", "check_int", "check_number", "real_array", "describe", "warn_user"]

_PACKAGE = str(Path(__file__).resolve().parent)


def warn_user(message: str, category=UserWarning) -> None:
    """``warnings.warn`` attributed to the first caller outside opnet: the line of the user's code that made
    the call, however deep inside opnet the problem was found.
    """
    level, frame = 2, sys._getframe(1)  # stacklevel 1 is this function, 2 its caller
    while frame is not None and str(Path(frame.f_code.co_filename).resolve()).startswith(_PACKAGE):
        level, frame = level + 1, frame.f_back
    warnings.warn(message, category, stacklevel=level)


def is_integer(value) -> bool:
    """A Python or numpy integer (``bool`` excluded)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def check_int(name: str, value, *, minimum: int = 1, none_ok: bool = False) -> int | None:
    """``value`` as an ``int`` ``>= minimum`` (``None`` passes when ``none_ok``); ``ValueError`` naming ``name``."""
    if value is None and none_ok:
        return None
    if not is_integer(value) or value < minimum:
        kind = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
        raise ValueError(f"{name} must be {kind}{' or None' if none_ok else ''}, got {value!r}.")
    return int(value)


def check_number(name: str, value, *, positive: bool = True) -> float:
    """``value`` as a finite ``float`` (``> 0`` when ``positive``); ``ValueError`` naming ``name``."""
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
    if not ok or not math.isfinite(value) or (positive and not value > 0):
        raise ValueError(f"{name} must be a {'positive' if positive else 'finite'} number, got {value!r}.")
    return float(value)


def describe(value) -> str:
    """What ``value`` is, for a message: ``float64 array of shape (2, 3)``, ``str``, ``list``."""
    if hasattr(value, "dtype") and hasattr(value, "shape"):
        return f"{str(value.dtype).replace('torch.', '')} {type(value).__name__} of shape {tuple(value.shape)}"
    return type(value).__name__


def _shape_text(shape) -> str:
    names = ["..." if s is Ellipsis else str(s) for s in shape]
    return "(" + ", ".join(names) + ("," if len(names) == 1 else "") + ")"


def real_array(name: str, value, shape=None, *, finite: bool = True, dtype=np.float64, hint: str = "") -> np.ndarray:
    """``value`` as a ``dtype`` (float64) array, or a ``TypeError``/``ValueError`` naming ``name``.

    Accepts numpy arrays, nested lists and CPU or GPU torch tensors (converted losslessly). Refuses strings,
    complex or non-numeric values, and (when ``finite``) NaN or infinite entries. ``shape`` is a tuple whose
    entries are sizes (``int``), or names of free sizes (``str``, e.g. ``("B", 1229, 3)``), or ``...`` as
    its first entry for any leading dimensions; ``hint`` follows the expected shape in messages (e.g. "to match
    the basis"). An array of ``dtype`` already is not copied.
    """
    if hasattr(value, "detach") and hasattr(value, "cpu"):  # a torch tensor
        value = value.detach().cpu()
        value = (value.float() if str(value.dtype) == "torch.bfloat16" else value).numpy()  # numpy has no bfloat16
    expected = (f" of shape {_shape_text(shape)}" if shape is not None else "") + (f" {hint}" if hint else "")
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a real array{expected}, got the string {value[:40]!r}; load the data first.")
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged lists and the like
        raise ValueError(f"{name} could not be read as an array ({exc}); pass a rectangular real array.") from None
    if arr.dtype.kind == "c":
        raise TypeError(
            f"{name} holds complex numbers; pass a real array{expected} (np.real(x) if the imaginary part is zero)."
        )
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a real array{expected}, got {arr.dtype} values ({describe(value)}).")
    if shape is not None and not _fits(arr.shape, shape):
        raise ValueError(f"{name} must have shape {_shape_text(shape)}{f' {hint}' if hint else ''}, got {arr.shape}.")
    if finite and not np.isfinite(arr).all():
        if arr.ndim == 0:
            raise ValueError(f"{name} is {arr.item()}; pass a finite number.")
        bad = np.argwhere(~np.isfinite(arr))
        raise ValueError(
            f"{name} contains {len(bad)} NaN or infinite values (first at index {tuple(bad[0].tolist())}); "
            "remove or repair them."
        )
    with np.errstate(over="ignore"):
        out = arr.astype(dtype, copy=False)
    if finite and out is not arr and out.dtype.kind == "f" and not np.isfinite(out).all():
        raise ValueError(
            f"{name} holds values beyond the range of {np.dtype(dtype)} (largest magnitude "
            f"{np.abs(arr).max():.3g}); rescale them."
        )
    return out


def _fits(actual: tuple, shape: tuple) -> bool:
    if shape and shape[0] is Ellipsis:
        shape = shape[1:]
        return len(actual) >= len(shape) and _fits(actual[len(actual) - len(shape) :], shape)
    return len(actual) == len(shape) and all(not is_integer(s) or a == s for a, s in zip(actual, shape))
