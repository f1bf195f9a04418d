"""The project's files agree with each other: environment.yml, pyproject.toml, the public API."""

import ast
import re
import subprocess
import sys
from pathlib import Path

import tomllib

import opnet

ROOT = Path(__file__).resolve().parents[1]
CONDA_TO_PYPI = {"pytorch": "torch"}


def names(requirements):
    return {CONDA_TO_PYPI.get(n, n).lower() for n in (re.split(r"[<>=!~ ]", r, maxsplit=1)[0] for r in requirements)}


def test_environment_yml_names_the_same_packages_as_pyproject():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = [r for group in project["optional-dependencies"].values() for r in group if not r.startswith("opnet[")]
    wanted = names(project["dependencies"]) | names(extras)
    conda, pip = set(), []
    text = (ROOT / "environment.yml").read_text()
    in_pip = False
    for line in text[text.index("dependencies:") :].splitlines()[1:]:
        item = line.split("#")[0].strip()
        if item == "- pip:":
            in_pip = True
        elif item.startswith("- ") and line.startswith("      ") and in_pip:
            pip.append(item[2:])
        elif item.startswith("- "):
            conda.add(item[2:])
    assert pip[-1] == "-e ."
    assert names(conda) - {"python", "pip"} | names(pip[:-1]) == wanted


def test_public_api_is_importable_and_complete():
    for name in opnet.__all__:
        try:
            getattr(opnet, name)
        except ImportError as exc:  # a core-only install: the name's extra is missing, and the message says so
            assert "pip install 'opnet[" in str(exc), name
    for name in (
        "Mesh",
        "MeshError",
        "load_mesh",
        "eigenbasis",
        "shape_difference",
        "gram_matrix",
        "recover_embedding",
        "interpolate",
        "analogy",
    ):
        assert name in opnet.__all__


def test_the_core_imports_neither_torch_nor_anny_nor_pyvista():
    """``import opnet`` and the core operators run without the extras' heavy packages (net, data, viz)."""
    code = (
        "import sys, opnet\n"
        "base, target = opnet.data.toy.finger_pair('quick')\n"
        "basis = opnet.eigenbasis(base, 10)\n"
        "opnet.shape_differences(basis, target.vertices[None], progress=False)\n"
        "opnet.recover_embedding(opnet.gram_matrix(basis, target.vertices), basis)\n"
        "heavy = ('torch', 'anny', 'pyvista', 'matplotlib', 'pyFM', 'pymeshlab', 'pymeshfix')\n"
        "print(sorted(m for m in heavy if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_a_missing_extra_is_named():
    """A module of an extra whose package is missing says which extra to install."""
    code = (
        "import sys; sys.modules['torch'] = None\n"  # as if torch were not installed
        "import opnet\n"
        "try:\n    opnet.OperatorNet\nexcept ImportError as e:\n    print(e)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "pip install 'opnet[net]'" in out


def test_functions_that_import_an_extra_name_it():
    """Functions importing an optional package where they use it (anny, pyvista, matplotlib, pyFM) say which
    extra brings it when it is missing, as do the others that go through ``opnet._extras.require``."""
    code = (
        "import sys\n"
        "for name in ('anny', 'pyvista', 'matplotlib', 'pyFM', 'ipywidgets', 'joblib', 'pymeshlab', "
        "'pymeshfix'):\n"
        "    sys.modules[name] = None\n"  # as if not installed
        "import numpy as np, opnet, opnet.matching, opnet.plotting\n"
        "from opnet._extras import EXTRAS, require\n"
        "base, target = opnet.data.toy.finger_pair('quick')\n"
        "calls = [\n"
        "    lambda: opnet.data.humans.human_faces(),\n"
        "    lambda: opnet.plotting.to_pyvista(base),\n"
        "    lambda: opnet.plotting.plot_operators([np.eye(3)]),\n"
        "    lambda: opnet.matching.compute_map(opnet.eigenbasis(base, 10), target, k=10, k_init=5),\n"
        "] + [lambda name=name: require(name, 'a test') for name in EXTRAS if name != 'torch']\n"
        "for call in calls:\n"
        "    try:\n        call()\n    except ImportError as e:\n        print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.splitlines()
    expected = ["data", "viz", "viz", "maps", "data", "data", "maps", "viz", "viz", "viz", *["animals"] * 2]
    assert len(out) == len(expected), out
    for line, extra in zip(out, expected):
        # the animals' extra is not in opnet[all] (GPL-3 packages): the message does not offer it
        also = "." if extra == "animals" else " (or 'opnet[all]')."
        assert line.endswith(f"pip install 'opnet[{extra}]'{also}"), line


def test_test_modules_share_helpers_through_conftest_only():
    """No test module imports another (a helper moved or renamed there would break an unrelated test): shared
    helpers and fixtures live in tests/conftest.py."""
    modules = {p.stem for p in (ROOT / "tests").glob("test_*.py")} | {"tests", "conftest"}
    for path in (ROOT / "tests").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):  # `from . import test_x` too
                names = [node.module or ""] + ([a.name for a in node.names] if node.level else [])
            else:
                continue
            parts = {part for n in names for part in n.split(".")}
            assert not modules & parts, f"{path.name} imports a test module: {names}"
