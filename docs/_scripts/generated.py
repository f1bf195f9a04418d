"""The docs' generated fragments: every shipped benchmark result rendered by its own script's ``report``, and
every shipped reproduction rendered by the report that wrote its ``results.md``.

``benchmarks/results/<script>.json`` is what ``benchmarks/<script>.py --json`` wrote on the machine it names
(``make benchmarks`` measures them all again); :func:`write_benchmark_fragments` renders each with that script's
``report(result)``, the function that also prints it, into ``docs/_generated/benchmarks/<script>.md``, which the
pages include. ``results/<preset>/`` holds what ``python -m opnet reproduce --preset <preset>`` wrote
(``results.json`` and ``figures/``, no checkpoints); :func:`write_results_fragments` renders each section of its
report (:func:`opnet.experiments.report.results_sections`) into ``docs/_generated/results/<preset>/<section>.md``
and copies its figures beside them, for the results page. ``docs/conf.py`` calls both at every build, so a page
cannot drift from its file.
"""

from __future__ import annotations

import importlib
import json
import shutil
import sys
from pathlib import Path

import opnet
from opnet.experiments.report import read_results, results_sections

#: The benchmarks of the checkout whose opnet the docs document (also when a copy of docs/ is built).
BENCHMARKS = Path(opnet.__file__).resolve().parents[1] / "benchmarks"
SHIPPED = BENCHMARKS / "results"
#: The shipped reproductions: ``results/<preset>/results.json`` and ``figures/``.
RESULTS = BENCHMARKS.parent / "results"


def benchmark_report(name: str, result: dict | None = None) -> str:
    """The Markdown report of benchmark ``name`` (``benchmarks/<name>.py``) on ``result`` (default: its shipped
    ``benchmarks/results/<name>.json``).
    """
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))  # the scripts import each other by file name, as when run
    module = importlib.import_module(name)
    if result is None:
        result = json.loads((SHIPPED / f"{name}.json").read_text())
    return module.report(result)


def write_benchmark_fragments(out: Path) -> list[Path]:
    """Write ``out/<name>.md`` for every shipped ``benchmarks/results/<name>.json``; the paths written."""
    if not SHIPPED.is_dir():
        raise FileNotFoundError(
            f"no shipped benchmark results at {SHIPPED}: build the docs against an opnet checkout installed with "
            "`pip install -e .` (the benchmarks and their results are not part of the installed package)."
        )
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for path in sorted(SHIPPED.glob("*.json")):
        written.append(_write(out / f"{path.stem}.md", benchmark_report(path.stem) + "\n"))
    return written


def _write(target: Path, text: str) -> Path:
    """Write ``text`` unless ``target`` holds it already (an unchanged file keeps its time: no rebuild)."""
    if not target.exists() or target.read_text() != text:
        target.write_text(text)
    return target


def write_results_fragments(out: Path, results: Path = RESULTS) -> list[Path]:
    """Write ``out/<preset>/<section>.md`` for every section of every shipped ``results/<preset>/results.json``,
    and copy its ``figures/*.png`` to ``out/<preset>/figures/``; the Markdown paths written.
    """
    shipped = sorted(results.glob("*/results.json"))
    if not shipped:
        raise FileNotFoundError(
            f"no shipped reproduction at {results}/<preset>/results.json: build the docs against an opnet checkout "
            "installed with `pip install -e .` (the shipped results are not part of the installed package)."
        )
    written = []
    for path in shipped:
        rows, context = read_results(path)
        folder = out / path.parent.name
        (folder / "figures").mkdir(parents=True, exist_ok=True)
        for name, lines in results_sections(rows, context).items():
            written.append(_write(folder / f"{name}.md", "\n".join(lines) + "\n"))
        for figure in sorted((path.parent / "figures").glob("*.png")):
            target = folder / "figures" / figure.name
            if not target.exists() or target.read_bytes() != figure.read_bytes():
                shutil.copyfile(figure, target)
    return written
