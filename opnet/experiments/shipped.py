"""The reproduction shipped with opnet: the ``results.json`` and figures that ``python -m opnet reproduce --preset
default`` wrote on the machine its context names, so that the notebooks and the docs can show the `default` numbers
beside a reader's own, without hours of training.

The files live in this package (``opnet/experiments/results/<preset>/``: ``results.json`` and ``figures/*.png``);
``make ship-results`` copies a finished reproduction there. Nothing here computes: it reads what was measured.
"""

from __future__ import annotations

from pathlib import Path

from .report import read_results

__all__ = ["SHIPPED_DIR", "shipped_presets", "shipped_results", "shipped_figure", "shipped_figures"]

#: Where the shipped reproductions are: one folder per preset, each with ``results.json`` and ``figures/``.
SHIPPED_DIR = Path(__file__).resolve().parent / "results"


def shipped_presets() -> list[str]:
    """The presets whose reproduction is shipped (folders of :data:`SHIPPED_DIR` holding a ``results.json``)."""
    if not SHIPPED_DIR.is_dir():
        return []
    return sorted(p.name for p in SHIPPED_DIR.iterdir() if (p / "results.json").is_file())


def _folder(preset: str) -> Path:
    folder = SHIPPED_DIR / preset
    if not (folder / "results.json").is_file():
        raise FileNotFoundError(
            f"no shipped reproduction for preset {preset!r} (shipped: {shipped_presets() or 'none'}); run "
            f"`python -m opnet reproduce --preset {preset} --out DIR` and read DIR with "
            "opnet.reproduce.read_results(DIR) instead."
        )
    return folder


def shipped_results(preset: str = "default") -> tuple[list[dict], dict]:
    """The rows and the context of the shipped reproduction at ``preset`` (:func:`opnet.reproduce.read_results` of its
    ``results.json``): rows with structured fields (``table``, ``run``, ``baseline``, ``split``, ``d_R`` in m² ...),
    and the context (``preset``, ``machine``, ``collection``, ``budget``, ``wall_seconds`` ...).

    Raises :class:`FileNotFoundError`, naming the presets that are shipped, when ``preset`` is not.
    """
    return read_results(_folder(preset) / "results.json")


def shipped_figures(preset: str = "default") -> list[str]:
    """The names of the shipped reproduction's figures at ``preset`` (``"training_curves"``, ``"ablation"`` ...)."""
    return sorted(p.stem for p in (_folder(preset) / "figures").glob("*.png"))


def shipped_figure(name: str, preset: str = "default") -> Path:
    """The path of the shipped figure ``name`` (``"ablation"``, ``"training_curves"``, ``"reconstructions_test"``
    ...; :func:`shipped_figures` lists them) of the reproduction at ``preset``: a PNG file.
    """
    path = _folder(preset) / "figures" / f"{name}.png"
    if not path.is_file():
        raise FileNotFoundError(
            f"the shipped {preset!r} reproduction has no figure {name!r}; it has {shipped_figures(preset)}."
        )
    return path
