"""opnet's layers read one way: every import (lazy ones included, relative or absolute, and ``import_module`` of a
module of opnet) points to a lower layer of the package, and inside opnet.data to a lower layer of the data package;
no module imports another's private names; only the adapter imports anny, in all of opnet; the geometry and the
channel layer import no torch when they load.

The package's layers are those of its intended layout (docs/api.md, "Package layout"), not fitted to the code:
geometry modules import nothing above them; the channel layer (inner products, shape differences, maps) sits on the
geometry; the collections (opnet.data) on both; torch-based modules import those, never the reverse; the front ends
(renders, widgets) sit on the torch-based ones; experiments, reproduce and ``__main__`` sit on top.
"""

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
    {"profiles"},
    {"mapped", "torch_dataset"},
    {"__init__"},
]
RANK = {name: i for i, layer in enumerate(LAYERS) for name in layer}
_IMPORTERS = ("require", "import_module")  # opnet._extras.require, importlib.import_module


#: The package's tiers, lowest first, each a list of layers (lowest first): a module imports only from the layers
#: below its own. The tiers and their order are the layout's; inside a tier, the layers order its modules among
#: themselves.
TIERS = {
    # the errors about its files; private helpers: argument checks, atomic files, optional imports, memos,
    # threads, deprecated names, CLI options
    "helpers": [{"errors"}, {"_checks", "_files", "_extras", "_memo", "_parallel", "options"}, {"_deprecation"}],
    # geometry in numpy/scipy, float64, no torch
    "geometry": [{"mesh"}, {"_backend", "algebra"}, {"spectral"}, {"fmaps", "gram", "metrics"}],
    # channels: inner products and the channel vocabulary, shape differences, maps and encode, the checkers
    "channels": [{"inner_products"}, {"shape_difference"}, {"matching", "testing"}],
    # the collections, built from the geometry and the channels
    "data": [{"data"}],
    # torch-based: devices, differentiable operators, networks; training and reconstruction (neither imports the
    # other); evaluation; the applications
    "torch": [{"devices", "torch_ops", "model"}, {"train", "geometric"}, {"evaluate"}, {"apps"}],
    # the front ends: renders and charts, widgets
    "front ends": [{"plotting"}, {"widgets"}],
    # on top: the experiments, the reproduction, the command line and the package's own namespace
    "top": [{"experiments"}, {"reproduce"}, {"__main__", "__init__"}],
}
PACKAGE_LAYERS = [layer for layers in TIERS.values() for layer in layers]
PACKAGE_RANK = {name: i for i, layer in enumerate(PACKAGE_LAYERS) for name in layer}
TIER = {name: tier for tier, layers in TIERS.items() for layer in layers for name in layer}
#: Tiers that load without torch: a module of theirs imports torch only inside the functions that need it.
NO_TORCH_TIERS = ("helpers", "geometry", "channels")
#: Names that any module may read from the package itself: its version, set before anything else is used.
_PACKAGE_METADATA = {"__version__"}


def _unit(path: Path, package: Path = PACKAGE) -> str:
    """The layer unit of a module: its top-level module or subpackage (``data``, ``train``, ``experiments``)."""
    return path.relative_to(package).with_suffix("").parts[0]


def _opnet_imports(path: Path, package: Path = PACKAGE):
    """``(units imported, private names imported)`` by a module of opnet, lazy imports included; a name imported
    from the package itself (``from opnet import KINDS``) is an import of ``__init__``.
    """
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
                for a in node.names:
                    is_module = (package / f"{a.name}.py").is_file() or (package / a.name).is_dir()
                    if is_module:
                        units.add(a.name)
                    elif a.name not in _PACKAGE_METADATA:
                        units.add("__init__")
            for a in node.names:
                submodule = (package / Path(*parts[1:]) / f"{a.name}.py").is_file() or (package / a.name).is_dir()
                if a.name.startswith("_") and not a.name.startswith("__") and not submodule:
                    private.add(f"{module}.{a.name}")
        elif isinstance(node, ast.Import):
            units.update(a.name.split(".")[1] for a in node.names if a.name.startswith("opnet."))
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            name = getattr(node.func, "id", None) or getattr(node.func, "attr", None)
            target = node.args[0].value
            if name == "import_module" and isinstance(target, str):  # importlib.import_module("opnet.x" or ".x")
                dotted = target if not target.startswith(".") else ".".join(here) + target
                if dotted.startswith("opnet.") and len(dotted.split(".")) > 1:
                    units.add(dotted.split(".")[1])
    return units, private


def _upward(path: Path) -> set:
    """The units a module of opnet imports from its own layer or a higher one (its own unit aside)."""
    unit = _unit(path)
    return {u for u in _opnet_imports(path)[0] - {unit} if PACKAGE_RANK.get(u, len(PACKAGE_RANK)) >= PACKAGE_RANK[unit]}


def _imports_torch_on_load(path: Path) -> bool:
    """Whether a module imports torch when it loads (an import statement outside any function)."""
    tree = ast.parse(path.read_text())
    inside = {
        id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef)) for n in ast.walk(f)
    }
    for node in ast.walk(tree):
        if id(node) in inside:
            continue
        if isinstance(node, ast.Import) and any(a.name.split(".")[0] == "torch" for a in node.names):
            return True
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "torch" and not node.level:
            return True
    return False


def test_every_package_module_has_a_layer():
    assert {_unit(p) for p in PACKAGE.rglob("*.py")} <= set(PACKAGE_RANK)


def test_imports_point_down_in_the_whole_package():
    for path in PACKAGE.rglob("*.py"):
        upward = _upward(path)
        assert not upward, f"{path.relative_to(PACKAGE)} imports {upward} from its own or a higher layer"


def test_the_geometry_and_the_channel_layer_load_without_torch():
    for path in PACKAGE.rglob("*.py"):
        if TIER[_unit(path)] in NO_TORCH_TIERS:
            assert not _imports_torch_on_load(path), f"{path.relative_to(PACKAGE)} imports torch when it loads"


def test_no_module_imports_another_modules_private_names():
    for path in PACKAGE.rglob("*.py"):
        private = _opnet_imports(path)[1]
        assert not private, f"{path.relative_to(PACKAGE)} imports the private names {sorted(private)}"


def test_the_package_check_can_fail(tmp_path):
    fake = tmp_path / "opnet" / "spectral.py"
    fake.parent.mkdir(parents=True)
    (tmp_path / "opnet" / "mesh.py").write_text("")
    for bad, found in (
        ("def f():\n    from .train import fit\n", ({"train"}, set())),
        ("from opnet.evaluate import decode\n", ({"evaluate"}, set())),
        ("from .mesh import _as_faces\n", ({"mesh"}, {"opnet.mesh._as_faces"})),
        ("def f():\n    from . import KINDS, mesh, __version__\n", ({"__init__", "mesh"}, set())),
        ("import importlib\nimportlib.import_module('.evaluate', __name__)\n", ({"evaluate"}, set())),
        ("import importlib\nimportlib.import_module('opnet.apps')\n", ({"apps"}, set())),
    ):
        fake.write_text(bad)
        assert _opnet_imports(fake, tmp_path / "opnet") == found, bad
    for bad in ("import torch\n", "from torch import nn\n", "if True:\n    import torch.nn\n"):
        fake.write_text(bad)
        assert _imports_torch_on_load(fake), bad
    fake.write_text("def f():\n    import torch\n")
    assert not _imports_torch_on_load(fake)


def test_the_layers_follow_the_layout():
    """The tiers' order is the layout's; a few of its arrows, spelled out."""
    assert list(TIERS) == ["helpers", "geometry", "channels", "data", "torch", "front ends", "top"]
    below = [("mesh", "inner_products"), ("inner_products", "shape_difference"), ("shape_difference", "matching")]
    below += [("matching", "data"), ("data", "torch_ops"), ("devices", "train"), ("devices", "geometric")]
    assert PACKAGE_RANK["train"] == PACKAGE_RANK["geometric"]  # siblings: reconstruction does not import the trainer
    below += [("train", "evaluate"), ("evaluate", "apps"), ("apps", "widgets"), ("data", "apps"), ("data", "widgets")]
    below += [("plotting", "experiments"), ("experiments", "reproduce"), ("reproduce", "__main__")]
    for low, high in below:
        assert PACKAGE_RANK[low] < PACKAGE_RANK[high], (low, high)


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
