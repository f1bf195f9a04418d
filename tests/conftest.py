"""Shared small meshes (a capsule base and smooth deformations of it, all in 1-1 correspondence), small collections
of them (the factories ``tiny_collection`` and ``toy_collection``), and the quick generated collections, read once
per session through the data cache."""

import json
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import opnet
from opnet.data import toy
from opnet.data.build import assemble
from opnet.data.generators import stem_name

# -- the tiers (markers declared in pyproject.toml) ----------------------------------------------------------------
#: Test modules whose every test belongs to a tier (other slow tests carry ``@pytest.mark.slow`` themselves).
_MODULE_TIERS = {
    "test_docs": "docs",
    "test_docs_site": "docs",
    "test_matching": "maps",
    "test_mapped": "maps",
    "test_anny_collections": "slow",
    "test_bodies": "slow",  # the body model: its first use builds a cache (about 15 s a model)
    "test_browser": "browser",
}
#: Fixtures that make a test slow: the generated collections (the body model builds them; minutes on a cold cache).
_SLOW_FIXTURES = {"humans", "quick_collection"}


def pytest_collection_modifyitems(config, items):
    """Mark the notebooks ``notebooks``, the docs tests ``docs``, the maps tests ``maps``, and every test that reads
    the generated humans ``slow`` (other slow tests carry the mark themselves)."""
    for item in items:
        path = item.path
        if path.suffix == ".ipynb":
            item.add_marker(pytest.mark.notebooks)
            item.add_marker(pytest.mark.slow)
            continue
        tier = _MODULE_TIERS.get(path.stem)
        if tier is not None:
            item.add_marker(getattr(pytest.mark, tier))
        if _SLOW_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def root(tmp_path_factory):
    """A data root for the generated collections of this test session."""
    return tmp_path_factory.mktemp("collections")


def _through_data_cache(name: str, root: Path):
    """The quick collection ``name``, read from the session's data root ``root``: built once into opnet's data cache
    (``OPNET_DATA_DIR``, else ``~/.cache/opnet``) and copied from there, so that a later test run (and ``make run``)
    does not build it again; where that cache cannot be written, built in ``root``.
    """
    try:
        cached = opnet.data.load_collection(name, "quick", progress=False)
    except (opnet.data.CollectionError, OSError):  # an unusable cache: build it here instead
        return opnet.data.load_collection(name, "quick", root, progress=False)
    opnet.data.save_collection(cached, root / stem_name(cached.meta))
    return opnet.data.load_collection(name, "quick", root, progress=False)


@pytest.fixture(scope="session")
def humans(root):
    """The quick humans, read from the session's data root (where the tests that build collections write), through
    the data cache (:func:`_through_data_cache`). A test that needs a fresh build makes one in its own folder.
    """
    return _through_data_cache("humans", root)


@pytest.fixture(scope="session")
def quick_collection(root):
    """``name`` → the quick collection ``name`` (``heads``, ``hands`` …), through the data cache like ``humans``: the
    body model builds one for minutes, and notebook 05 reads the same files."""
    return lambda name: _through_data_cache(name, root)


@pytest.fixture(scope="session")
def base():
    return toy.capsule("quick")


@pytest.fixture(scope="session")
def targets(base):
    """Three deformed copies of the base: pose (bend), area (bulge) and both."""
    v = base.vertices
    return [
        base.with_vertices(toy.bend(v, np.deg2rad(50))),
        base.with_vertices(toy.bulge(v, 0.3)),
        base.with_vertices(toy.bend(toy.bulge(v, -0.2, center=0.5), np.deg2rad(-80), joint=-0.3)),
    ]


@pytest.fixture(scope="session")
def base_basis(base):
    return opnet.eigenbasis(base, 30)


@pytest.fixture(scope="session")
def full_basis(base):
    return opnet.eigenbasis(base, base.n_vertices)


@pytest.fixture(scope="session")
def small_shapes():
    """A 162-vertex sphere and three smooth deformations of it, for tests that need full n × n bases."""
    import trimesh

    s = trimesh.creation.icosphere(2)
    v = np.asarray(s.vertices)
    base = opnet.Mesh(v, s.faces)
    deformed = [
        v * np.array([1.3, 1.0, 0.8]),
        v * (1 + 0.3 * np.exp(-4 * np.sum((v - [0, 0, 1]) ** 2, axis=1)))[:, None],
        toy_twist(v),
    ]
    return base, [base.with_vertices(d) for d in deformed]


def toy_twist(v):
    ang = 0.8 * v[:, 2]
    c, s = np.cos(ang), np.sin(ang)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], 1.2 * v[:, 2]], axis=1)


# -- small collections of toy capsules (no body model), built by the tests that need them --------------------------


def _tiny_collection(name="tiny", n=40, seed=0):
    """``n`` bent and bulged capsules (430 vertices, k = 20) with train / val / test / test_subjects splits."""
    rng = np.random.default_rng(seed)
    base = toy.capsule("quick")
    angles, amounts = rng.uniform(-1.2, 1.2, n), rng.uniform(-0.25, 0.3, n)
    V = np.stack([toy.bend(toy.bulge(base.vertices, b), a) for a, b in zip(angles, amounts)])
    split = np.array(["train"] * (n - 12) + ["val"] * 4 + ["test"] * 4 + ["test_subjects"] * 4)
    sub = np.array([f"s{i // 4}" for i in range(n)])
    meta = dict(name=name, preset="tiny", resolution="430", seed=seed, generator_version="test")
    return assemble(V, base.faces, base.vertices, split, sub, sub, {"angle": angles}, meta, k=20, progress=False)


def _toy_collection(seed=0, n_subjects=4, groups=("bend", "bulge", "both"), frames=3):
    """Capsules of ``n_subjects`` widths × ``groups`` (bend, bulge, both) × ``frames``, split by
    :func:`opnet.data.make_splits` like the generated collections (k = 20)."""
    rng = np.random.default_rng(seed)
    base = toy.capsule("quick")
    V, subj, grp = [], [], []
    for s in range(n_subjects):
        width = rng.uniform(0.8, 1.2)
        for g in groups:
            for t in np.linspace(0.2, 1.0, frames):
                v = base.vertices * [width, width, 1.0]
                if g in ("bend", "both"):
                    v = toy.bend(v, t * 1.2)
                if g in ("bulge", "both"):
                    v = toy.bulge(v, 0.4 * t)
                V.append(v)
                subj.append(s)
                grp.append(g)
    subj, grp = np.array(subj), np.array(grp)
    split = opnet.data.make_splits(subj, grp, rng, n_test_subcollections=2, n_test_subjects=1, n_val_subcollections=1)
    names = np.array([f"subject{s:02d}" for s in subj])
    sub = np.array([f"{name}/{g}" for name, g in zip(names, grp)])
    meta = dict(name="toy", preset="quick", resolution="quick", seed=seed, generator_version="test")
    return assemble(
        np.stack(V), base.faces, base.vertices, split, sub, names, {"group": grp}, meta, k=20, progress=False, n_eval=2
    )


@pytest.fixture(scope="session")
def tiny_collection():
    """The factory of tiny collections, ``tiny_collection(name="tiny", n=40, seed=0)`` (a fresh one per call)."""
    return _tiny_collection


@pytest.fixture(scope="session")
def toy_collection():
    """The factory of toy collections with subjects and motions, ``toy_collection(seed=0, n_subjects=4, ...)``."""
    return _toy_collection


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="session")
def free_port():
    """``free_port()``: a TCP port on 127.0.0.1 that no process listens on now (the OS picks it)."""
    return _free_port


class _Unrendered:
    """In place of a pyvista plotter (:func:`recorded_figures`): its screenshot writes a stand-in file."""

    def screenshot(self, path):
        Path(path).write_bytes(b"png")

    def close(self):
        pass


@pytest.fixture
def recorded_figures(monkeypatch):
    """``recorded_figures(*names)``: the figure functions ``names`` of :mod:`opnet.plotting` recorded instead of
    rendered (seconds a figure on a CPU); returns name → the list of each call's ``(args, kwargs)``, and the plotter
    each call returns writes a stand-in PNG. A call the real function would refuse (an argument it does not take, one
    missing) fails as it would. tests/test_plotting.py renders them."""
    import inspect

    import opnet.plotting

    def record(*names):
        calls = {name: [] for name in names}
        for name in names:
            signature = inspect.signature(getattr(opnet.plotting, name))

            def fake(*args, _calls=calls[name], _signature=signature, **kwargs):
                _signature.bind(*args, **kwargs)  # TypeError where the real function would raise it
                _calls.append((args, kwargs))
                return _Unrendered()

            monkeypatch.setattr(f"opnet.plotting.{name}", fake)
        return calls

    return record


def _run_cli(*args, env=None, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "opnet", *args], capture_output=True, text=True, env=env, **kw)


@pytest.fixture(scope="session")
def cli():
    """``cli(*args, env=None, **kw)``: ``python -m opnet *args`` in a subprocess, output captured as text."""
    return _run_cli


# -- the documentation site, built once per session (tests/test_docs_site.py, tests/test_browser.py) ---------------

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _sphinx_build(source: Path, out: Path) -> subprocess.CompletedProcess:
    """``make docs``'s build (warnings are errors, nitpicky) of the pages in ``source`` into ``out``."""
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-n", "-q", "-b", "html", str(source), str(out)]
    return subprocess.run(command, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="session")
def sphinx_build():
    """``sphinx_build(source, out)``: the documentation build of ``source`` into ``out`` (a completed process)."""
    return _sphinx_build


@pytest.fixture(scope="session")
def docs_site(tmp_path_factory):
    """``(html, result)``: the site of ``docs/`` built once per session into ``html`` (15 s to 1.5 min on 2 cores)."""
    out = tmp_path_factory.mktemp("docs_site") / "html"
    return out, _sphinx_build(DOCS, out)


def _markdown_tables(notebook: Path) -> list[str]:
    return [  # the Markdown tables the notebook displays (Table 1, the ablation, the applications' tables)
        text
        for cell in json.loads(notebook.read_text())["cells"]
        for output in cell.get("outputs", [])
        if "|---" in (text := "".join(output.get("data", {}).get("text/markdown", "")))
    ]


@pytest.fixture(scope="session")
def markdown_tables():
    """``markdown_tables(notebook)``: the Markdown tables (text) that a notebook's saved outputs display."""
    return _markdown_tables


@pytest.fixture
def profile_loads(monkeypatch):
    """``profile_loads(name, coll)``: for this test, the collection profile ``name`` (:mod:`opnet.data.profiles`)
    loads ``coll`` whatever the preset, root or draws asked for."""
    import dataclasses

    def use(name: str, coll):
        p = opnet.data.profile(name)
        monkeypatch.setitem(opnet.data.PROFILES, name, dataclasses.replace(p, load=lambda *a, **k: coll))

    return use
