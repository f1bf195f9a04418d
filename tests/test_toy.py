"""The toy shapes are closed, outward-oriented, in correspondence, and deform where they say."""

import numpy as np
import pytest

import opnet
from opnet.data import toy


@pytest.mark.parametrize("preset", ["quick", "default"])
def test_capsule_is_a_closed_outward_surface(preset):
    m = toy.capsule(preset)
    r, length = 0.25, 2.0
    assert opnet.mesh_volume(m.vertices, m.faces) == pytest.approx(
        np.pi * r**2 * length + 4 / 3 * np.pi * r**3, rel=0.04
    )  # inscribed 16-gon: -2.6 %
    assert m.area == pytest.approx(2 * np.pi * r * length + 4 * np.pi * r**2, rel=0.02)
    e = opnet.mesh.unique_edges(m.faces)
    assert len(m.vertices) - len(e) + len(m.faces) == 2  # a sphere's Euler characteristic


def test_deformations_keep_correspondence_and_act_locally():
    base, target = toy.finger_pair("quick")
    assert np.array_equal(base.faces, target.faces)
    v = toy.capsule("quick").vertices
    bulged = toy.bulge(v, 0.5)
    far = np.abs(v[:, 2] + 0.6) > 1.0
    np.testing.assert_allclose(bulged[far], v[far], atol=1e-3)
    bent = toy.bend(v, np.deg2rad(90))
    below = v[:, 2] < 0.2 - 0.6
    np.testing.assert_allclose(bent[below], v[below])
    np.testing.assert_allclose(np.linalg.norm(bent - [0, 0, 0.2], axis=1), np.linalg.norm(v - [0, 0, 0.2], axis=1))
    with pytest.raises(ValueError, match="preset"):
        toy.capsule("huge")
