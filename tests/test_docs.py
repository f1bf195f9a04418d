"""The code blocks of README.md and docs/*.md run as written.

Each document's Python blocks run top to bottom in one namespace (as a reader pasting them into one session
would), in a temporary folder that holds the files the pages read as "your own data": ``body.ply`` (a closed
body mesh of another triangulation) and ``my_registrations/`` (meshes in correspondence). A block preceded by
``<!-- docs-test: skip (reason) -->`` is not run. Shell blocks are not run (they start the long jobs); every
``python -m opnet ...`` line in them is parsed by the command-line parser, so a renamed flag fails here.
"""

import re
import shlex
from pathlib import Path

import pytest
import trimesh

from opnet.__main__ import _parser
from opnet.data.generators import generate_shapes
from opnet.data.humans import human_faces

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"(?P<mark><!-- docs-test: skip[^>]*-->\n)?```(?P<lang>\w+)\n(?P<code>.*?)\n```", re.S)


def blocks(path: Path, lang: str) -> list[str]:
    """The ``lang`` blocks of ``path`` that are to be run, in order."""
    return [m["code"] for m in FENCE.finditer(path.read_text()) if m["lang"] == lang and not m["mark"]]


def run_blocks(path: Path) -> None:
    """Run the Python blocks of ``path`` in one namespace; a failing block fails the test, naming it."""
    namespace = {"__name__": "__docs__"}
    for n, block in enumerate(blocks(path, "python")):
        try:
            exec(compile(block, f"{path.name}[python block {n}]", "exec"), namespace)
        except Exception as exc:
            pytest.fail(f"{path.name}, Python block {n} fails: {type(exc).__name__}: {exc}\n{block}")


def test_blocks_are_found_and_broken_ones_fail(tmp_path):
    """The extraction and the runner themselves: the README and the usage page hold Python and shell blocks, the skip
    mark drops a block, and a block using an undefined name (as an old README's sixth line did) fails."""
    assert len(blocks(ROOT / "README.md", "python")) >= 2 and blocks(ROOT / "README.md", "bash")
    assert len(blocks(ROOT / "docs" / "usage.md", "python")) >= 5
    doc = tmp_path / "doc.md"
    doc.write_text("<!-- docs-test: skip (why) -->\n```python\nboom()\n```\n\n```python\nx = 1\n```\n")
    assert blocks(doc, "python") == ["x = 1"]
    run_blocks(doc)
    doc.write_text("```python\nimport opnet\nDs = opnet.shape_differences(basis, many_vertices)\n```\n")
    with pytest.raises(pytest.fail.Exception, match="NameError"):
        run_blocks(doc)


@pytest.fixture
def reader_folder(tmp_path, monkeypatch, humans, root):
    """A working folder with the pages' input files; collections come from the session's data root."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("OPNET_DATA_DIR", str(root))
    i = int(humans.indices("test")[0])
    body = generate_shapes(humans, humans.params["phenotypes"][[i]], humans.params["controls"][[i]], resolution="2k")
    trimesh.Trimesh(body[0], human_faces("2k"), process=False).export(tmp_path / "body.ply")
    folder = tmp_path / "my_registrations"
    folder.mkdir()
    for j in humans.indices("train")[:4]:
        trimesh.Trimesh(humans.vertices[j], humans.faces, process=False).export(folder / f"shape{j:04d}.ply")
    return tmp_path


@pytest.mark.parametrize("path", DOCUMENTS, ids=lambda p: p.name)
def test_python_blocks_run(path, reader_folder):
    run_blocks(path)


@pytest.mark.parametrize("path", DOCUMENTS, ids=lambda p: p.name)
def test_command_lines_parse(path):
    parser = _parser()
    lines = "\n".join(blocks(path, "bash")).replace("\\\n", " ").splitlines()
    for line in lines:
        words = shlex.split(line, comments=True)
        if words[:3] == ["python", "-m", "opnet"] and "..." not in words:
            parser.parse_args(words[3:])  # SystemExit on an unknown flag or value


def test_the_readme_is_short_and_its_table1_is_the_shipped_one():
    """The README stays a front door (at most 10 KB), and its headline Table 1 is the one rendered from the shipped
    `default` reproduction (opnet.experiments.report.headline_markdown), so the two cannot drift apart."""
    from opnet.experiments.report import headline_markdown
    from opnet.experiments.shipped import shipped_results

    readme = (ROOT / "README.md").read_text()
    assert len(readme.encode()) <= 10_000
    assert "../shared" not in readme  # a path outside the repository, that a user does not have
    for page in (ROOT / "docs").glob("*.md"):  # the docs hold their own text: none depends on the README
        assert "../README.md" not in page.read_text(), page.name
    block = readme[readme.index("<!-- headline-table1 -->") : readme.index("<!-- headline-table1-end -->")]
    expected = headline_markdown(*shipped_results("default"))
    assert expected and block.strip().splitlines()[1:] == expected
    assert expected[-1].startswith("Measured ")  # when, where and at which budget the shipped file was measured


def test_ship_results_renders_the_readmes_headline_from_the_rows(tmp_path):
    """``make ship-results`` rewrites the block between the README's markers from the rows it ships
    (docs/_scripts/generated.py --readme), keeping the rest of the file."""
    import sys

    sys.path.insert(0, str(ROOT / "docs" / "_scripts"))
    from generated import HEADLINE_MARKERS, write_readme_headline

    from opnet.experiments.report import headline_markdown
    from opnet.experiments.shipped import shipped_results

    start, end = HEADLINE_MARKERS
    readme = tmp_path / "README.md"
    readme.write_text(f"# title\n\nbefore\n{start}\n| stale | table |\n{end}\n\nafter\n")
    rows, context = shipped_results("default")
    write_readme_headline(readme, rows, context)
    text = readme.read_text()
    assert text.startswith("# title\n\nbefore\n") and text.endswith(f"{end}\n\nafter\n") and "stale" not in text
    assert text[text.index(start) : text.index(end)].strip().splitlines()[1:] == headline_markdown(rows, context)
    readme.write_text("no markers\n")
    with pytest.raises(ValueError, match="headline-table1"):
        write_readme_headline(readme, rows, context)


#: Decimal numbers docs/results.md may quote that none of its sources prints, each with where it comes from.
RESULTS_UNPRINTED = {
    "1.067": "a seed's tail ratio in benchmarks/results/schedules-quick-short.json (its report: converged or not)",
    "3.909": "3.466 + 0.443: the schedule rule's tie-break, computed in the text",
    # the one-seed reproductions at a constant rate that the seeded one replaced, quoted as history:
    "0.771": "OperatorNet (Int+Ext), test, the file shipped in d4c64d2 (git show d4c64d2:opnet/experiments/results/…)",
    "1.14": "OperatorNet (Int+Ext), test, the file shipped from 85968bc to 2d44bfe",
    "0.913": "OperatorNet (Ext), test, the file shipped from 85968bc to 2d44bfe",
    "0.589": "OperatorNet (Int), test, the file shipped from 85968bc to 2d44bfe",
    "1.12": "OperatorNet (Int+Ext), the discretisation table's 1k exact row, the file shipped until 2d44bfe",
}


def test_every_decimal_number_the_results_page_quotes_is_in_what_it_renders():
    """docs/results.md's prose quotes only numbers that the fragments it includes (the shipped reproductions' sections
    and the benchmarks' reports, rendered at every build) or notebook 05's stored outputs (its `quick` heads and hands)
    print, or one of RESULTS_UNPRINTED: prose left stale when a shipped result is measured again fails here."""
    import json
    import sys

    sys.path.insert(0, str(ROOT / "docs" / "_scripts"))
    from generated import benchmark_report, results_fragments

    rendered = {  # what docs/conf.py writes under docs/_generated at each build
        "results": results_fragments("default"),
        "results-animals": results_fragments("default", "animals"),
    }
    decimal = re.compile(r"(?<![\w.\-/])\d+\.\d+(?![\w.])")
    page = (ROOT / "docs" / "results.md").read_text()
    held = []
    for folder, name in re.findall(r"```\{include\} _generated/([\w-]+)/([\w-]+)\.md\n```", page):
        held.append(benchmark_report(name) if folder == "benchmarks" else rendered[folder][name])
    assert len(held) == page.count("{include}")  # every include read
    for cell in json.loads((ROOT / "notebooks" / "05_interpolation_analogy.ipynb").read_text())["cells"]:
        for out in cell.get("outputs", []):
            held += ["".join(out.get("text", [])), "".join(out.get("data", {}).get("text/markdown", []))]
    held = "\n".join(held)
    prose = re.sub(r"```.*?```", "", page, flags=re.S)  # not the includes, nor code
    missing = sorted({n for n in decimal.findall(prose) if n not in held and n not in RESULTS_UNPRINTED})
    assert not missing, f"docs/results.md quotes numbers nothing it renders prints: {missing}"
