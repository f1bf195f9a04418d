"""Optional dependencies: import one, or say which of opnet's extras brings it.

The core (``import opnet``, the operators, Theorem 1) needs numpy, scipy, trimesh, potpourri3d and tqdm;
the rest comes with an extra of ``pyproject.toml`` and is imported where it is used, through :func:`require`.
"""

from __future__ import annotations

import importlib

#: The extra that brings each optional package (``pyproject.toml``'s optional-dependencies).
EXTRAS = {
    "torch": "net",
    "anny": "data",
    "joblib": "data",
    "pyFM": "maps",
    "pyvista": "viz",
    "matplotlib": "viz",
    "ipywidgets": "viz",
    "pymeshlab": "animals",
    "pymeshfix": "animals",
}


#: The extras that ``opnet[all]`` leaves out (the animals': pymeshlab and pymeshfix are GPL-3, opnet MIT).
NOT_IN_ALL = {"animals"}


def missing_extra(exc: ModuleNotFoundError, needed_by: str) -> ImportError | None:
    """An ImportError naming the extra to install, when ``exc`` is about an optional package (else None)."""
    top = (exc.name or "").partition(".")[0]
    if top not in EXTRAS:
        return None
    extra = EXTRAS[top]
    also = "" if extra in NOT_IN_ALL else " (or 'opnet[all]')"
    return ImportError(f"{needed_by} needs {top}, which is not installed: pip install 'opnet[{extra}]'{also}.")


def require(module: str, needed_by: str):
    """Import ``module`` (e.g. ``"pyvista"``, ``"pyFM.functional"``); a missing optional package raises an
    ImportError that names ``needed_by`` and the extra to install.
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        error = missing_extra(exc, needed_by)
        if error is None:
            raise
        raise error from exc
