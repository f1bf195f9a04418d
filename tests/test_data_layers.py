"""The data package's layers read one way: every import inside opnet.data (lazy ones included) points to a lower
layer, and only the adapter imports anny."""

import ast
from pathlib import Path

import opnet

DATA = Path(opnet.__file__).parent / "data"
LAYERS = [
    {"storage", "splits", "subjects", "motion", "toy"},
    {"build", "anny_adapter"},
    {"humans", "heads", "hands"},
    {"generators", "folder"},
    {"mapped", "torch_dataset"},
    {"__init__"},
]
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}


def _imports(path: Path):
    """(sibling modules imported, top-level packages imported) by a module of opnet.data, at any depth."""
    siblings, packages = set(), set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            siblings |= {node.module} if node.module else {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            packages.add(node.module.partition(".")[0])
        elif isinstance(node, ast.Import):
            packages |= {a.name.partition(".")[0] for a in node.names}
        elif isinstance(node, ast.Call) and getattr(node.func, "id", None) == "require" and node.args:
            packages.add(node.args[0].value.partition(".")[0])
    return {s.partition(".")[0] for s in siblings}, packages


def test_every_module_has_a_layer():
    assert {p.stem for p in DATA.glob("*.py")} == set(RANK)


def test_imports_point_down_and_only_the_adapter_imports_anny():
    for path in DATA.glob("*.py"):
        siblings, packages = _imports(path)
        upward = {s for s in siblings if RANK[s] >= RANK[path.stem]}
        assert not upward, f"{path.name} imports {upward} from its own or a higher layer"
        assert ("anny" in packages) == (path.stem == "anny_adapter"), path.name


def test_the_layer_check_can_fail(tmp_path):
    bad = tmp_path / "storage.py"
    bad.write_text("def f():\n    from .generators import load_collection\n    import anny\n")
    siblings, packages = _imports(bad)
    assert siblings == {"generators"} and "anny" in packages
