"""The data package's layers read one way: every import inside opnet.data (lazy ones included, relative or
absolute) points to a lower layer, and only the adapter imports anny, in all of opnet."""

import ast
from pathlib import Path

import opnet

PACKAGE = Path(opnet.__file__).parent
DATA = PACKAGE / "data"
LAYERS = [
    {"storage", "splits", "subjects", "motion", "toy"},
    {"build", "anny_adapter"},
    {"humans", "heads", "hands"},
    {"generators", "folder"},
    {"mapped", "torch_dataset"},
    {"__init__"},
]
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}
_IMPORTERS = ("require", "import_module")  # opnet._extras.require, importlib.import_module


def _imports(path: Path, package: Path = PACKAGE):
    """(modules of opnet.data imported, top-level packages imported) by a module of opnet (laid out under
    ``package``), at any depth."""
    here = ["opnet", *path.relative_to(package).with_suffix("").parts[:-1]]
    modules = []  # dotted names of what is imported
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = ".".join(here[: len(here) - node.level + 1]) if node.level else ""
            module = ".".join(p for p in (base, node.module) if p)
            modules += [module] + [f"{module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            modules += [a.name for a in node.names]
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            name = getattr(node.func, "id", None) or getattr(node.func, "attr", None)
            if name in _IMPORTERS and isinstance(node.args[0].value, str):
                modules.append(node.args[0].value)
    data = {m.split(".")[2] for m in modules if m.startswith("opnet.data.") and m.split(".")[2] in RANK}
    return data, {m.split(".")[0] for m in modules}


def test_every_module_has_a_layer():
    assert {p.stem for p in DATA.rglob("*.py")} == set(RANK)


def test_imports_point_down():
    for path in DATA.rglob("*.py"):
        upward = {m for m in _imports(path)[0] if RANK[m] >= RANK[path.stem]}
        assert not upward, f"{path.name} imports {upward} from its own or a higher layer"


def test_only_the_adapter_imports_anny():
    importers = {str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py") if "anny" in _imports(p)[1]}
    assert importers == {"data/anny_adapter.py"}


def test_the_layer_check_can_fail(tmp_path):
    storage = DATA / "storage.py"
    for bad in (
        "def f():\n    from .generators import load_collection\n",
        "from ..data.generators import load_collection\n",
        "import opnet.data.generators\n",
        "from opnet.data import generators\n",
        "def f():\n    return _extras.require('anny', 'x')\n",
        "import importlib\nimportlib.import_module('anny.models')\n",
    ):
        fake = tmp_path / "opnet" / "data" / "storage.py"
        fake.parent.mkdir(parents=True, exist_ok=True)
        fake.write_text(bad)
        data, packages = _imports(fake, tmp_path / "opnet")
        assert "generators" in data or "anny" in packages, bad
    assert _imports(storage)[0] <= {"storage", "splits", "subjects", "motion", "toy"}
