"""Shared small meshes (a capsule base and smooth deformations of it, all in 1-1 correspondence), and the quick
humans generated once per session."""

import numpy as np
import pytest

import opnet
from opnet.data import toy


@pytest.fixture(scope="session")
def root(tmp_path_factory):
    """A data root for the generated collections of this test session."""
    return tmp_path_factory.mktemp("collections")


@pytest.fixture(scope="session")
def humans(root):
    return opnet.data.load_collection("humans", "quick", root, progress=False)


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
