"""The project's files agree with each other: environment.yml, pyproject.toml, the public API."""

import re
from pathlib import Path

import tomllib

import opnet

ROOT = Path(__file__).resolve().parents[1]
CONDA_TO_PYPI = {"pytorch": "torch"}


def names(requirements):
    return {CONDA_TO_PYPI.get(n, n).lower() for n in (re.split(r"[<>=!~ ]", r, maxsplit=1)[0] for r in requirements)}


def test_environment_yml_names_the_same_packages_as_pyproject():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    wanted = names(project["dependencies"]) | names(project["optional-dependencies"]["test"])
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
        assert hasattr(opnet, name), name
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
