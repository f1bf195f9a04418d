"""opnet's layers read one way: every import (lazy ones included, relative or absolute) of a module of opnet points
to a lower layer of the package, and inside opnet.data to a lower layer of the data package; no module imports
another's private names; only the adapter imports anny, in all of opnet."""

import ast
from pathlib import Path

import opnet

PACKAGE = Path(opnet.__file__).parent
DATA = PACKAGE / "data"
LAYERS = [
    {"channels"},
    {"storage", "splits", "subjects", "motion", "toy"},
    {"build", "anny_adapter"},
    {"humans", "heads", "hands", "animals"},
    {"generators", "folder"},
    {"mapped", "torch_dataset"},
    {"__init__"},
]
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}
_IMPORTERS = ("require", "import_module")  # opnet._extras.require, importlib.import_module


#: The package's layers, lowest first: geometry in numpy, then the data, then torch, then what sits on top.
PACKAGE_LAYERS = [
    {"_checks", "_files", "_extras", "_memo", "_parallel"},
    {"mesh"},
    {"_backend", "algebra"},
    {"spectral"},
    {"fmaps", "gram", "metrics"},
    {"inner_products"},
    {"shape_difference", "testing"},
    {"matching"},
    {"data"},
    {"torch_ops", "model"},
    {"train"},
    {"geometric"},
    {"evaluate"},
    {"apps", "plotting"},
    {"experiments", "widgets"},
    {"reproduce"},
    {"__main__", "__init__"},
]
PACKAGE_RANK = {name: i for i, layer in enumerate(PACKAGE_LAYERS) for name in layer}


def _unit(path: Path, package: Path = PACKAGE) -> str:
    """The layer unit of a module: its top-level module or subpackage (``data``, ``train``, ``experiments``)."""
    return path.relative_to(package).with_suffix("").parts[0]


def _opnet_imports(path: Path, package: Path = PACKAGE):
    """``(units imported, private names imported)`` by a module of opnet, lazy imports included."""
    here = ["opnet", *path.relative_to(package).with_suffix("").parts[:-1]]
    units, private = set(), set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = ".".join(here[: len(here) - node.level + 1]) if node.level else ""
            module = ".".join(p for p in (base, node.module) if p)
            if module != "opnet" and not module.startswith("opnet."):
                continue
            parts = module.split(".")
            if len(parts) > 1:
                units.add(parts[1])
            else:
                units.update(a.name for a in node.names)
            for a in node.names:
                submodule = (package / Path(*parts[1:]) / f"{a.name}.py").is_file() or (package / a.name).is_dir()
                if a.name.startswith("_") and not a.name.startswith("__") and not submodule:
                    private.add(f"{module}.{a.name}")
        elif isinstance(node, ast.Import):
            units.update(a.name.split(".")[1] for a in node.names if a.name.startswith("opnet."))
    return units, private


def test_every_package_module_has_a_layer():
    assert {_unit(p) for p in PACKAGE.rglob("*.py")} <= set(PACKAGE_RANK)


def test_imports_point_down_in_the_whole_package():
    for path in PACKAGE.rglob("*.py"):
        unit = _unit(path)
        upward = {u for u in _opnet_imports(path)[0] - {unit} if PACKAGE_RANK.get(u, -1) >= PACKAGE_RANK[unit]}
        assert not upward, f"{path.relative_to(PACKAGE)} imports {upward} from its own or a higher layer"


def test_no_module_imports_another_modules_private_names():
    for path in PACKAGE.rglob("*.py"):
        private = _opnet_imports(path)[1]
        assert not private, f"{path.relative_to(PACKAGE)} imports the private names {sorted(private)}"


def test_the_package_check_can_fail(tmp_path):
    fake = tmp_path / "opnet" / "spectral.py"
    fake.parent.mkdir(parents=True)
    for bad, found in (
        ("def f():\n    from .train import fit\n", ({"train"}, set())),
        ("from opnet.evaluate import decode\n", ({"evaluate"}, set())),
        ("from .mesh import _as_faces\n", ({"mesh"}, {"opnet.mesh._as_faces"})),
    ):
        fake.write_text(bad)
        assert _opnet_imports(fake, tmp_path / "opnet") == found, bad


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


def _data_unit(path: Path) -> str:
    """The layer unit of a module of opnet.data: its module or its subpackage (``animals``)."""
    return path.relative_to(DATA).with_suffix("").parts[0]


def test_every_module_has_a_layer():
    assert {_data_unit(p) for p in DATA.rglob("*.py")} == set(RANK)


def test_imports_point_down():
    for path in DATA.rglob("*.py"):
        unit = _data_unit(path)
        upward = {m for m in _imports(path)[0] - {unit} if RANK[m] >= RANK[unit]}
        assert not upward, f"{path.relative_to(DATA)} imports {upward} from its own or a higher layer"


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
    assert _imports(storage)[0] <= {"channels", "storage", "splits", "subjects", "motion", "toy"}
