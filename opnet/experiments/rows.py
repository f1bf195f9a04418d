"""Rows found by their structured fields: :func:`matches` and :func:`row_channels`, shared by the report, the
targets and the figures (nothing finds a row by its display name).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from ..inner_products import channel_names

__all__ = ["row_channels", "matches", "as_rows", "number_text"]


def as_rows(rows) -> list[dict]:
    """``rows`` as a list of result rows (any iterable of dicts), or a ``ValueError`` that says what rows are."""
    try:
        rows = None if isinstance(rows, (str, bytes, Mapping)) else list(rows)
    except TypeError:
        rows = None
    if rows is None or not all(isinstance(r, Mapping) for r in rows):
        raise ValueError("rows must be a list of result rows (dicts), e.g. those of opnet.ablation or read_results.")
    return rows


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


def number_text(value, scale: float = 1.0, digits: int = 3) -> str:
    """``value × scale`` as the tables and claims print a number: ``digits`` significant digits, ``"–"`` where it is
    missing (``None``) or not finite (a NaN of a path that did not move).
    """
    return "–" if value is None or not math.isfinite(value) else f"{scale * value:.{digits}g}"
