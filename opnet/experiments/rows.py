"""Rows found by their structured fields: :func:`matches` and :func:`row_channels`, shared by the report, the
targets and the figures (nothing finds a row by its display name).
"""

from __future__ import annotations

from ..inner_products import channel_names

__all__ = ["row_channels", "matches"]


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
