"""Old names that keep working for a while: each warns once per process, then does what the new name does.

The warning is a :class:`DeprecationWarning`, not a :class:`FutureWarning`: the old names are API that code
calls (``collection.kinds``, ``with_kinds``, ``kinds=``), so the warning is meant for whoever writes that code.
Python shows it where that code runs in ``__main__``, in a notebook (IPython) and under pytest, attributed to the
user's line (:func:`opnet._checks.warn_user`), and hides it where a library the user does not own calls the old
name; a ``FutureWarning`` would be shown to every end user of such a library too.
"""

from __future__ import annotations

import functools

from ._checks import warn_user

__all__ = ["warn_renamed", "renamed_keyword"]

#: The old names that have warned in this process (a test clears it to see a warning again).
WARNED: set[str] = set()


def warn_renamed(old: str, new: str) -> None:
    """Warn, the first time in this process only, that ``old`` is deprecated in favour of ``new``."""
    if old in WARNED:
        return
    WARNED.add(old)
    warn_user(
        f"{old} is deprecated: use {new}, the same thing under opnet's one name for the operators' channels. "
        f"{old} keeps working for now (this warning is shown once).",
        DeprecationWarning,
    )


def renamed_keyword(old: str, new: str, *, where: str | None = None):
    """A decorator: the function also takes its keyword ``new`` under the old name ``old`` (deprecated, warns once
    per process); both together raise a ``TypeError``. ``where``: the function's name in the messages (default its
    qualified name).
    """

    def decorate(func):
        name = where or func.__qualname__

        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            if old in kwargs:
                if new in kwargs:
                    raise TypeError(f"{name}() got both {new}= and its deprecated name {old}=; pass only {new}=.")
                warn_renamed(f"{name}({old}=...)", f"{name}({new}=...)")
                kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        return wrapper

    return decorate
