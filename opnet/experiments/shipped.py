"""The reproduction shipped with opnet: the ``results.json`` and figures that ``python -m opnet reproduce --preset
default`` wrote on the machine its context names, so that the notebooks and the docs can show the `default` numbers
beside a reader's own, without hours of training.

The files live in this package (``opnet/experiments/results/<preset>/``: ``results.json`` and ``figures/*.png``);
``make ship-results`` copies a finished reproduction there. Nothing here computes: it reads what was measured.
"""

from __future__ import annotations

from pathlib import Path

from ..data.profiles import profile, reproducible
from .report import read_results

__all__ = ["SHIPPED_DIR", "shipped_presets", "shipped_results", "shipped_figure", "shipped_figures"]

#: Where the shipped reproductions are: one folder per collection and preset (``default`` for the humans,
#: ``animals-default`` for the animals), each with ``results.json`` and ``figures/``.
SHIPPED_DIR = Path(__file__).resolve().parent / "results"


def _folder_name(preset: str, collection: str) -> str:
    if collection not in reproducible():
        raise ValueError(f"collection must be one of {list(reproducible())}, got {collection!r}.")
    if not isinstance(preset, str) or "-" in preset:
        raise ValueError(
            f"preset must be a preset's name such as 'default', got {preset!r}; give the collection as "
            "collection=, e.g. shipped_results('default', 'animals')."
        )
    return profile(collection).folder(preset)


def shipped_presets(collection: str = "humans") -> list[str]:
    """The presets whose reproduction of ``collection`` (a reproducible profile: ``"humans"``, ``"animals"``) is
    shipped.
    """
    _folder_name("default", collection)  # refuses an unknown collection
    prefix = profile(collection).folder_prefix
    if not SHIPPED_DIR.is_dir():
        return []
    shipped = (p.name for p in SHIPPED_DIR.iterdir() if (p / "results.json").is_file())
    return sorted(
        name.removeprefix(prefix) for name in shipped if name.startswith(prefix) and "-" not in name[len(prefix) :]
    )


def _folder(preset: str, collection: str) -> Path:
    folder = SHIPPED_DIR / _folder_name(preset, collection)
    if not (folder / "results.json").is_file():
        other = f" --collection {collection}" if profile(collection).folder_prefix else ""
        raise FileNotFoundError(
            f"no shipped reproduction of the {collection} for preset {preset!r} (shipped: "
            f"{shipped_presets(collection) or 'none'}); run `python -m opnet reproduce --preset {preset}{other} "
            "--out DIR` and read DIR with opnet.reproduce.read_results(DIR) instead."
        )
    return folder


def shipped_results(preset: str = "default", collection: str = "humans") -> tuple[list[dict], dict]:
    """The rows and the context of the shipped reproduction of ``collection`` (``"humans"``, the paper's Table 1, or
    ``"animals"``) at ``preset`` (:func:`opnet.reproduce.read_results` of its ``results.json``): rows with
    structured fields (``table``, ``run``, ``baseline``, ``split``, ``d_R`` in m² ...), and the context (``preset``,
    ``machine``, ``collection``, ``budget``, ``wall_seconds`` ...).

    Raises :class:`FileNotFoundError`, naming the presets that are shipped, when ``preset`` is not.
    """
    return read_results(_folder(preset, collection) / "results.json")


def shipped_figures(preset: str = "default", collection: str = "humans") -> list[str]:
    """The names of the shipped reproduction's figures of ``collection`` at ``preset`` (``"training_curves"``,
    ``"ablation"`` ...).
    """
    return sorted(p.stem for p in (_folder(preset, collection) / "figures").glob("*.png"))


def shipped_figure(name: str, preset: str = "default", collection: str = "humans") -> Path:
    """The path of the shipped figure ``name`` (``"ablation"``, ``"training_curves"``, ``"reconstructions_test"``
    ...; :func:`shipped_figures` lists them) of the reproduction of ``collection`` at ``preset``: a PNG file.
    """
    path = _folder(preset, collection) / "figures" / f"{name}.png"
    if not path.is_file():
        raise FileNotFoundError(
            f"the shipped {preset!r} reproduction of the {collection} has no figure {name!r}; it has "
            f"{shipped_figures(preset, collection)}."
        )
    return path
