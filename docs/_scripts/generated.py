"""The docs' generated fragments: every shipped benchmark result rendered by its own script's ``report``.

``benchmarks/results/<script>.json`` is what ``benchmarks/<script>.py --json`` wrote on the machine it names
(``make benchmarks`` measures them all again); :func:`write_benchmark_fragments` renders each with that script's
``report(result)``, the function that also prints it, into ``docs/_generated/benchmarks/<script>.md``, which the
pages include. ``docs/conf.py`` calls it at every build, so a page cannot drift from its file.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import opnet

#: The benchmarks of the checkout whose opnet the docs document (also when a copy of docs/ is built).
BENCHMARKS = Path(opnet.__file__).resolve().parents[1] / "benchmarks"
SHIPPED = BENCHMARKS / "results"


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
        target = out / f"{path.stem}.md"
        text = benchmark_report(path.stem) + "\n"
        if not target.exists() or target.read_text() != text:  # unchanged files keep their time: no rebuild
            target.write_text(text)
        written.append(target)
    return written
