"""The notebooks' exercises: each has its solution in a code cell tagged ``solution``, collapsed with its printed
answer in JupyterLab (``source_hidden``, ``outputs_hidden``) and on the docs site (``hide-cell``), which checks its
own result with ``assert``; nbval runs those cells with the rest of the notebook (the ``notebooks`` tier), so a
solution that stops working fails a test. This fast test checks the structure, and that every cell whose output
nbval compares holds that output (a notebook saved without it would fail only in the slow tier)."""

import json
import re
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("0*.ipynb"))
UNEXECUTED = re.compile(r"<details>.*?```python", re.S)  # a solution written as Markdown: nothing runs it


def _cells(path: Path) -> list[dict]:
    return json.loads(path.read_text())["cells"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_exercise_has_a_collapsed_solution_that_checks_itself(path):
    cells = _cells(path)
    solutions = [(i, c) for i, c in enumerate(cells) if "solution" in c["metadata"].get("tags", [])]
    assert len(solutions) >= 2, f"{path.name}: expected at least two exercises with solution cells"
    for i, cell in solutions:
        source = "".join(cell["source"])
        assert cell["cell_type"] == "code", f"{path.name}: cell {i} is tagged solution but is not code"
        hidden = cell["metadata"].get("jupyter", {})
        assert hidden.get("source_hidden") and hidden.get("outputs_hidden"), f"{path.name}: solution cell {i} is shown"
        assert "hide-cell" in cell["metadata"]["tags"], f"{path.name}: solution cell {i} lacks the hide-cell tag"
        assert re.search(r"^\s*assert\b", source, re.M), f"{path.name}: solution cell {i} checks nothing"
        exercises = ["".join(c["source"]) for c in cells[:i] if c["cell_type"] == "markdown"]
        assert exercises and "Exercise" in exercises[-1], f"{path.name}: solution cell {i} follows no exercise"
    markdown = "".join("".join(c["source"]) for c in cells if c["cell_type"] == "markdown")
    assert not UNEXECUTED.search(markdown), f"{path.name}: a solution is written in Markdown, where nothing runs it"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_cells_whose_output_nbval_checks_hold_their_output(path):
    cells = [c for c in _cells(path) if c["cell_type"] == "code"]
    empty = [i for i, c in enumerate(cells) if "NBVAL_CHECK_OUTPUT" in "".join(c["source"]) and not c.get("outputs")]
    assert not empty, (
        f"{path.name}: code cells {empty} are checked by nbval but were saved without outputs; run make run"
    )


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_outputs_come_from_one_run_of_the_whole_notebook_without_warnings(path):
    """The stored outputs are what the prose is checked against: every code cell ran, in order, in one kernel
    (execution counts 1, 2, 3 …), and nothing went to stderr (a warning or a library's banner in a tutorial)."""
    cells = [c for c in _cells(path) if c["cell_type"] == "code"]
    counts = [c.get("execution_count") for c in cells]
    assert counts == list(range(1, len(cells) + 1)), f"{path.name}: not one run of every cell in order: {counts}"
    noisy = [i for i, c in enumerate(cells) if any(o.get("name") == "stderr" for o in c.get("outputs", []))]
    assert not noisy, f"{path.name}: code cells {noisy} wrote to stderr"


#: Decimal numbers a notebook's prose may quote that no code or output of that notebook holds, each with its source.
UNPRINTED = {
    ("03_training", "2.4"): "a torch version",
    ("07_your_own_inner_product", "1.7"): "the base's area in m², which notebook 01 prints",
}
DECIMAL = re.compile(r"(?<![\w.\-/])\d+\.\d+(?![\w.])")
ARXIV = re.compile(r"\b\d{4}\.\d{5}\b")  # the paper's arXiv id


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_decimal_number_the_text_quotes_is_in_the_notebooks_code_or_outputs(path):
    """A number with a decimal point in a Markdown cell is one the notebook's code or stored outputs (text and tables)
    hold, or one of :data:`UNPRINTED`: a run whose numbers moved (another machine's round-off, another budget) and
    was stored without its prose read again fails here. Figures' titles are images: prose reads them without numbers.
    """
    cells = _cells(path)
    held = []
    for c in cells:
        if c["cell_type"] != "code":
            continue
        held.append("".join(c["source"]))
        for o in c.get("outputs", []):
            data = o.get("data", {})
            for text in (o.get("text"), data.get("text/plain"), data.get("text/markdown"), data.get("text/html")):
                held.append("".join(text) if isinstance(text, list) else text or "")
    held = "\n".join(held)
    quoted = {
        (i, n)
        for i, c in enumerate(cells)
        if c["cell_type"] == "markdown"
        for n in DECIMAL.findall(ARXIV.sub("", "".join(c["source"])))
    }
    missing = sorted((i, n) for i, n in quoted if n not in held and (path.stem, n) not in UNPRINTED)
    assert not missing, f"{path.name}: Markdown cells quote numbers no output prints (cell, number): {missing}"
