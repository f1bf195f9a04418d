"""The documentation site builds as ``make docs`` builds it, and a broken cross-reference fails that build.

Sphinx runs with ``-W --keep-going -n`` (warnings are errors; nitpicky: every reference, in the pages and in the
docstrings, must resolve) into a temporary folder. The notebooks are rendered from their committed outputs, never
executed, so a build takes about 15 s on 2 cores.
"""

import re
import shutil
import sys
from pathlib import Path

import pytest

if sys.version_info < (3, 11):  # Sphinx 9, myst-nb and the theme need 3.11: the docs extra installs none there
    pytest.skip("the documentation site needs Python 3.11 or later", allow_module_level=True)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_scripts"))
from generated import benchmark_report, results_fragments  # noqa: E402

#: the page each shipped ``benchmarks/results/<name>.json`` is rendered on, when not the benchmarks page
RESULT_PAGES = {
    "matching": "results",
    "refinement": "results",
    "scaling": "results",
    "variants": "results",
    "schedules": "results",
    "schedules-quick": "results",
    "schedules-quick-short": "results",
    "extrinsic": "results",
    "offset_channels": "inner_products",
    "generalisation": "results",
    "fault_soak": "data",
    "cluster": "data",
}
REMOTE_ASSET = re.compile(r"<(?:script|link|img)\b[^>]*\b(?:src|href)=\"(?:https?:)?//[^\"]+\"")


def test_site_builds_with_every_reference_resolved_and_nothing_remote(docs_site, markdown_tables):
    out, result = docs_site  # built once per session (tests/conftest.py), also opened in Chromium by test_browser
    assert result.returncode == 0, result.stderr[-6000:]
    assert (out / "index.html").is_file() and (out / "api" / "opnet.spectral.html").is_file()
    for notebook in sorted((ROOT / "notebooks").glob("0*.ipynb")):
        page = (out / "tutorials" / f"{notebook.stem}.html").read_text()
        assert "<img" in page, f"{notebook.name}: no figure rendered"
        tables = markdown_tables(notebook)
        if tables:  # rendered as tables, not as a paragraph of `| ... |` text
            raw = re.search(r"<p>\|[^<]*\|---", page)  # a table left as a paragraph of its source text
            assert page.count("<table") >= len(tables) and raw is None, f"{notebook.name}: a table shown as text"
    shipped = sorted((ROOT / "benchmarks" / "results").glob("*.json"))
    page_of = {path.stem: RESULT_PAGES.get(path.stem, "benchmarks") for path in shipped}
    pages = {name: (out / f"{name}.html").read_text() for name in {"benchmarks", *page_of.values()}}
    on_benchmarks = [name for name, page in page_of.items() if page == "benchmarks"]
    assert on_benchmarks and pages["benchmarks"].count("<table") == len(on_benchmarks)  # one table per measurement
    for path in shipped:  # each rendered from its file: its table's cells are on its page
        report = benchmark_report(path.stem)
        body = report[report.index("|---") :].splitlines()[1:]
        cells = [c.strip() for line in body if line.startswith("|") for c in line.strip("|").split("|")]
        page = page_of[path.stem]
        missing = [c for c in cells if re.fullmatch(r"[\d,.]+", c) and f">{c}<" not in pages[page]]
        assert not missing, f"{path.name}: cells not on the {page} page: {missing[:5]}"
    results = (out / "results.html").read_text()
    for collection in ("humans", "animals"):  # the shipped reproductions: each section on the page
        for name, text in results_fragments("default", collection).items():
            lines = text.splitlines()
            cells = [c.strip().strip("*") for line in lines if line.startswith("| ") for c in line.split("|")]
            missing = [c for c in cells if re.fullmatch(r"[\d.]+( \([\d.]+\))?", c) and f">{c}<" not in results]
            assert not missing, f"shipped {collection} {name}: cells not on the results page: {missing[:5]}"
            tabled = (
                ("table1", "ablation") if collection == "humans" else ("table1", "applications")
            )  # animals: no ablation
            assert cells or name not in tabled, f"shipped {collection} {name}: no table"
    for page in out.rglob("*.html"):  # offline: no script, stylesheet, font or picture fetched at view time
        assert not REMOTE_ASSET.search(page.read_text()), f"{page.relative_to(out)} loads a remote asset"


def test_a_broken_reference_fails_the_build(tmp_path, sphinx_build):
    """The site's configuration with two API pages (whose references resolve among themselves) and a page naming a
    function that does not exist and one that does: the build fails on the first alone. The whole site's build, with
    every reference resolved, is the test above; building a copy of the whole site here took 27 s more on 2 cores.
    """
    source = tmp_path / "docs"
    source.mkdir()
    for name in ("conf.py", "_scripts", "_static"):
        copy = shutil.copytree if (ROOT / "docs" / name).is_dir() else shutil.copy
        copy(ROOT / "docs" / name, source / name)
    pages = ("opnet.spectral", "opnet.mesh")  # opnet.eigenbasis is documented on the first
    (source / "api").mkdir()
    for page in pages:
        shutil.copy(ROOT / "docs" / "api" / f"{page}.md", source / "api")
    (source / "index.md").write_text("# opnet\n\n```{toctree}\n" + "".join(f"api/{p}\n" for p in pages) + "```\n")
    (source / "broken.md").write_text(
        "---\norphan: true\n---\n\n# Broken\n\nSee {func}`opnet.no_such_function` and {func}`opnet.eigenbasis`.\n"
    )
    result = sphinx_build(source, tmp_path / "html")
    assert result.returncode != 0
    problems = [line for line in result.stderr.splitlines() if "WARNING" in line or "ERROR" in line]
    assert len(problems) == 1 and "broken.md" in problems[0], result.stderr[-6000:]
    assert "reference target not found: opnet.no_such_function" in problems[0]
