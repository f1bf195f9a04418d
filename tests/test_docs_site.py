"""The documentation site builds as ``make docs`` builds it, and a broken cross-reference fails that build.

Sphinx runs with ``-W --keep-going -n`` (warnings are errors; nitpicky: every reference, in the pages and in the
docstrings, must resolve) into a temporary folder. The notebooks are rendered from their committed outputs, never
executed, so a build takes about 15 s on 2 cores.
"""

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

if sys.version_info < (3, 11):  # Sphinx 9, myst-nb and the theme need 3.11: the docs extra installs none there
    pytest.skip("the documentation site needs Python 3.11 or later", allow_module_level=True)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_scripts"))
from generated import benchmark_report  # noqa: E402

REMOTE_ASSET = re.compile(r"<(?:script|link|img)\b[^>]*\b(?:src|href)=\"(?:https?:)?//[^\"]+\"")


def sphinx_build(source: Path, out: Path) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-q", "-b", "html", str(source), str(out)]
    return subprocess.run(command, capture_output=True, text=True, timeout=600)


def test_site_builds_with_every_reference_resolved_and_nothing_remote(tmp_path):
    out = tmp_path / "html"
    result = sphinx_build(ROOT / "docs", out)
    assert result.returncode == 0, result.stderr[-6000:]
    assert (out / "index.html").is_file() and (out / "api" / "opnet.spectral.html").is_file()
    for notebook in sorted((ROOT / "notebooks").glob("0*.ipynb")):
        page = (out / "tutorials" / f"{notebook.stem}.html").read_text()
        assert "<img" in page, f"{notebook.name}: no figure rendered"
        tables = [  # the Markdown tables the notebook displays (Table 1, the ablation, the applications' tables)
            text
            for cell in json.loads(notebook.read_text())["cells"]
            for output in cell.get("outputs", [])
            if "|---" in (text := "".join(output.get("data", {}).get("text/markdown", "")))
        ]
        if tables:  # rendered as tables, not as a paragraph of `| ... |` text
            raw = re.search(r"<p>\|[^<]*\|---", page)  # a table left as a paragraph of its source text
            assert page.count("<table") >= len(tables) and raw is None, f"{notebook.name}: a table shown as text"
    benchmarks = (out / "benchmarks.html").read_text()
    shipped = sorted((ROOT / "benchmarks" / "results").glob("*.json"))
    assert shipped and benchmarks.count("<table") == len(shipped)  # one table per shipped measurement
    for path in shipped:  # each rendered from its file: its table's cells are on the page
        report = benchmark_report(path.stem)
        body = report[report.index("|---") :].splitlines()[1:]
        cells = [c.strip() for line in body if line.startswith("|") for c in line.strip("|").split("|")]
        missing = [c for c in cells if re.fullmatch(r"[\d,.]+", c) and f">{c}<" not in benchmarks]
        assert not missing, f"{path.name}: cells not on the benchmarks page: {missing[:5]}"
    for page in out.rglob("*.html"):  # offline: no script, stylesheet, font or picture fetched at view time
        assert not REMOTE_ASSET.search(page.read_text()), f"{page.relative_to(out)} loads a remote asset"


def test_a_broken_reference_fails_the_build(tmp_path):
    """A copy of docs/ with one more page naming a function that does not exist: the build fails on it."""
    source = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", source)  # follows docs/tutorials' links: real copies of the notebooks
    (source / "broken.md").write_text(
        "---\norphan: true\n---\n\n# Broken\n\nSee {func}`opnet.no_such_function` and {func}`opnet.eigenbasis`.\n"
    )
    result = sphinx_build(source, tmp_path / "html")
    assert result.returncode != 0
    problems = [line for line in result.stderr.splitlines() if "WARNING" in line or "ERROR" in line]
    assert len(problems) == 1 and "broken.md" in problems[0], result.stderr[-6000:]
    assert "reference target not found: opnet.no_such_function" in problems[0]
