"""The docs' generated fragments: every shipped result rendered by the code that also prints it.

- ``benchmarks/results/<script>.json`` is what ``benchmarks/<script>.py --json`` wrote on the machine it names
  (``make benchmarks`` measures them all again); :func:`write_benchmark_fragments` renders each with that script's
  ``report(result)`` into ``docs/_generated/benchmarks/<script>.md``.
- The shipped reproduction (``opnet.experiments.shipped``: the ``results.json`` and figures of ``python -m opnet
  reproduce --preset default``): :func:`write_results_fragments` renders each section of its ``results.md``
  (``opnet.experiments.report.results_sections``) into ``docs/_generated/results/<section>.md`` and copies its
  figures to ``docs/_generated/results/figures/``; the animals' (``--collection animals``) go to
  ``docs/_generated/results-animals/``.

``docs/conf.py`` calls both at every build, so a page cannot drift from its file. The README's headline Table 1 is
rendered from the same rows by :func:`write_readme_headline` (``make ship-results`` calls it: ``python
docs/_scripts/generated.py --readme README.md``), and a test keeps the two equal.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import opnet
from opnet.experiments.report import SECTION_TITLES, headline_markdown, results_sections
from opnet.experiments.shipped import shipped_figure, shipped_figures, shipped_results

#: The benchmarks of the checkout whose opnet the docs document (also when a copy of docs/ is built).
BENCHMARKS = Path(opnet.__file__).resolve().parents[1] / "benchmarks"
SHIPPED = BENCHMARKS / "results"


def benchmark_report(name: str, result: dict | None = None) -> str:
    """The Markdown report of benchmark ``name`` (``benchmarks/<name>.py``) on ``result`` (default: its shipped
    ``benchmarks/results/<name>.json``). A result of one script at other settings is named ``<script>-<what>``
    (``schedules-quick``: ``benchmarks/schedules.py --preset quick``).
    """
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))  # the scripts import each other by file name, as when run
    module = importlib.import_module(name.partition("-")[0])
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
        written.append(_write_if_changed(target, benchmark_report(path.stem) + "\n"))
    return written


def _write_if_changed(target: Path, content: str | bytes) -> Path:
    data = content.encode() if isinstance(content, str) else content
    if not target.exists() or target.read_bytes() != data:  # unchanged files keep their time: no rebuild
        target.write_bytes(data)
    return target


def results_fragments(preset: str = "default", collection: str = "humans") -> dict[str, str]:
    """Name → Markdown of the shipped reproduction of ``collection`` at ``preset``: each section of its
    ``results.md`` (every name of ``SECTION_TITLES``; a section the shipped run has no rows for says so).
    """
    rows, context = shipped_results(preset, collection)
    sections = results_sections(rows, context)
    other = "" if collection == "humans" else f" --collection {collection}"
    missing = (
        f"*Not in the shipped `{preset}` reproduction yet*; `python -m opnet reproduce --preset {preset}{other}` "
        "computes it (a call with only that part, into a copy of the shipped folder, adds it to the rest)."
    )
    return {name: "\n".join(sections.get(name) or [missing]) + "\n" for name in SECTION_TITLES}


def write_results_fragments(out: Path, preset: str = "default", collection: str = "humans") -> list[Path]:
    """Write ``out/<name>.md`` for every :func:`results_fragments` and copy the shipped figures to
    ``out/figures/<name>.png``; the paths written.
    """
    (out / "figures").mkdir(parents=True, exist_ok=True)
    fragments = results_fragments(preset, collection)
    written = [_write_if_changed(out / f"{name}.md", text) for name, text in fragments.items()]
    for name in shipped_figures(preset, collection):
        figure = shipped_figure(name, preset, collection).read_bytes()
        written.append(_write_if_changed(out / "figures" / f"{name}.png", figure))
    return written


#: The README's markers around its headline Table 1.
HEADLINE_MARKERS = ("<!-- headline-table1 -->", "<!-- headline-table1-end -->")


def write_readme_headline(readme: Path, rows: list[dict] | None = None, context: dict | None = None) -> Path:
    """Replace the headline Table 1 between the README's :data:`HEADLINE_MARKERS` by
    :func:`~opnet.experiments.report.headline_markdown` of ``rows`` and their file's ``context`` (default: the
    shipped `default` reproduction's); the rest of the file is kept. Returns the path.
    """
    readme = Path(readme)
    text = readme.read_text()
    start, end = HEADLINE_MARKERS
    if text.count(start) != 1 or text.count(end) != 1 or text.index(start) > text.index(end):
        raise ValueError(f"{readme} must hold {start} and then {end} once each, around its headline table.")
    lines = headline_markdown(*(shipped_results("default") if rows is None else (rows, context)))
    if not lines:
        raise ValueError("the rows hold no Table 1 row to put in the README's headline.")
    before, rest = text.split(start)
    after = rest.split(end)[1]
    return _write_if_changed(readme, f"{before}{start}\n" + "\n".join(lines) + f"\n{end}{after}")


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description="Render the shipped results into the README's headline table.")
    parser.add_argument("--readme", type=Path, required=True, help="the README to update in place")
    print(write_readme_headline(parser.parse_args().readme))
