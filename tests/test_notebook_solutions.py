"""The exercises' solutions (Python blocks in the notebooks' collapsible ``<details>``) parse, and every name they
take from opnet exists: nbval does not run them (they are markdown), so an API change would otherwise leave them
silently broken. Their numbers were checked when they were written, at the quick preset. And every cell whose output
nbval compares holds that output (a notebook saved without it fails only in the slow tier)."""

import ast
import importlib
import inspect
import json
import re
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[1] / "notebooks").glob("0*.ipynb"))
SOLUTION = re.compile(r"<details>.*?```python\n(.*?)```.*?</details>", re.S)


def _cells(path: Path, kind: str) -> list[str]:
    return ["".join(c["source"]) for c in json.loads(path.read_text())["cells"] if c["cell_type"] == kind]


def _opnet_modules(code: str) -> dict:
    """Names bound to opnet modules by the imports in ``code``: ``{"opnet": opnet, "plotting": opnet.plotting}``."""
    bound = {}
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.Import):
            bound |= {(a.asname or a.name): a.name for a in node.names if a.name.split(".")[0] == "opnet"}
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "opnet":
            bound |= {(a.asname or a.name): f"{node.module}.{a.name}" for a in node.names}
    return bound


def _resolve(dotted: str):
    """The object ``dotted`` names (a module, or an attribute of one), imported as needed."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for attr in parts[cut:]:
            try:
                obj = getattr(obj, attr)
            except ImportError as exc:  # an extra that a core-only install lacks
                pytest.skip(f"{dotted}: {exc}")
        return obj
    raise ImportError(dotted)


def _attribute_chains(tree) -> set[str]:
    """``a.b.c`` for every attribute access on a plain name (the longest chains)."""
    chains = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and not isinstance(getattr(node, "parent", None), ast.Attribute):
            parts, cur = [], node
            while isinstance(cur, ast.Attribute):
                parts.append(cur.attr)
                cur = cur.value
            if isinstance(cur, ast.Name):
                chains.add(".".join([cur.id, *reversed(parts)]))
    return chains


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_solutions_parse_and_name_real_opnet_functions(path):
    solutions = [s for cell in _cells(path, "markdown") for s in SOLUTION.findall(cell)]
    assert len(solutions) >= 2, f"{path.name}: expected two or three exercises with solutions"
    modules = _opnet_modules("\n".join(_cells(path, "code") + solutions))
    for code in solutions:
        tree = ast.parse(code)
        for node in ast.walk(tree):
            for child in ast.iter_child_nodes(node):
                child.parent = node
        for chain in _attribute_chains(tree):
            head, *rest = chain.split(".")
            if head not in modules or not rest:
                continue
            obj = _resolve(modules[head])
            for i, attr in enumerate(rest):
                if not hasattr(obj, attr):  # of a module: missing; of a class: maybe an instance attribute
                    missing = f"{head}.{'.'.join(rest[: i + 1])}"
                    assert not inspect.ismodule(obj), f"{path.name}: a solution uses {missing}, which does not exist"
                    break
                obj = getattr(obj, attr)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_cells_whose_output_nbval_checks_hold_their_output(path):
    cells = [c for c in json.loads(path.read_text())["cells"] if c["cell_type"] == "code"]
    empty = [i for i, c in enumerate(cells) if "NBVAL_CHECK_OUTPUT" in "".join(c["source"]) and not c.get("outputs")]
    assert not empty, (
        f"{path.name}: code cells {empty} are checked by nbval but were saved without outputs; run make run"
    )
