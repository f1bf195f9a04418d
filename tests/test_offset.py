"""FuncChar's offset-surface channels (opnet.OffsetAreaInnerProduct, OffsetConformalInnerProduct) and the vertex
normals they offset along: against an explicit construction of the offset mesh, on a sphere where the offset is a
scaling, in the limit t → 0, under rigid motions, and through the checks a researcher's own channel must pass.
"""

import numpy as np
import pytest
import trimesh

import opnet
from opnet.inner_products import OFFSET, OffsetAreaInnerProduct, OffsetConformalInnerProduct, offset_surface
from opnet.testing import check_inner_product

OFFSET_KINDS = ("offset_area", "offset_conformal")


def slow_offset(vertices, faces, t):
    """The offset mesh built vertex by vertex: each vertex moved along the normalised sum of its faces' area
    vectors (½ (b − a) × (c − a)), by t √(total area)."""
    normals = np.zeros_like(vertices)
    area = 0.0
    for a, b, c in faces:
        cross = np.cross(vertices[b] - vertices[a], vertices[c] - vertices[a])
        area += 0.5 * np.linalg.norm(cross)
        for i in (a, b, c):
            normals[i] += 0.5 * cross
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return vertices + t * np.sqrt(area) * normals


@pytest.mark.parametrize("kind, plain", [("offset_area", "area"), ("offset_conformal", "conformal")])
def test_an_offset_channel_is_its_plain_channel_on_the_explicit_offset_mesh(targets, base_basis, kind, plain):
    faces, phi = base_basis.mesh.faces, base_basis.evecs
    for shape in targets:
        moved = slow_offset(shape.vertices, faces, OFFSET)
        expected = opnet.get_inner_product(plain).project(moved, faces, phi)
        got = opnet.get_inner_product(kind).project(shape.vertices, faces, phi)
        np.testing.assert_allclose(got, expected, rtol=1e-10, atol=1e-12 * np.abs(expected).max())
        assert np.abs(got - opnet.get_inner_product(plain).project(shape.vertices, faces, phi)).max() > 1e-6


def test_on_a_sphere_the_offset_is_a_scaling():
    """A sphere of radius R offset by d along its normals is the sphere of radius R + d: every vertex area grows by
    (1 + d / R)² (the first-order term is 2 d H A with H = 1 / R), and cotangent weights do not change."""
    s = trimesh.creation.icosphere(3)
    v, f = np.asarray(s.vertices), np.asarray(s.faces)
    basis = opnet.eigenbasis(opnet.Mesh(v, f), 20)
    normals = opnet.vertex_normals(v, f)
    assert np.abs(np.sum(normals * v, axis=1) - 1).max() < 1e-4  # outward and nearly radial on the unit sphere
    for t in (0.01, 0.05):
        d = t * np.sqrt(opnet.vertex_areas(v, f).sum())
        area = opnet.get_inner_product("area").project(v, f, basis.evecs)
        offset = OffsetAreaInnerProduct(t).project(v, f, basis.evecs)
        np.testing.assert_allclose(offset, (1 + d) ** 2 * area, rtol=0, atol=1e-3 * np.abs(area).max())
        conformal = opnet.get_inner_product("conformal").project(v, f, basis.evecs)
        offset = OffsetConformalInnerProduct(t).project(v, f, basis.evecs)
        np.testing.assert_allclose(offset, conformal, rtol=0, atol=1e-3 * np.abs(conformal).max())


@pytest.mark.parametrize("cls, plain", [(OffsetAreaInnerProduct, "area"), (OffsetConformalInnerProduct, "conformal")])
def test_as_t_goes_to_zero_the_change_is_first_order(targets, base_basis, cls, plain):
    faces, phi, v = base_basis.mesh.faces, base_basis.evecs, targets[2].vertices
    K0 = opnet.get_inner_product(plain).project(v, faces, phi)
    changes = [cls(t).project(v, faces, phi) - K0 for t in (1e-4, 5e-5)]
    assert np.abs(cls(0.0).project(v, faces, phi) - K0).max() == 0  # t = 0 is the plain channel
    # halving t halves the change, up to a second-order term
    np.testing.assert_allclose(changes[1], changes[0] / 2, rtol=0, atol=2e-3 * np.abs(changes[0]).max())


@pytest.mark.parametrize("kind", OFFSET_KINDS)
def test_offset_channels_pass_the_checks_and_ignore_rigid_motions(base, base_basis, kind):
    report = check_inner_product(kind, base)  # symmetric, PSD, batch and torch forms equal project
    assert report["rigid_invariant"] and report["torch_equals_numpy"] in (True, None)
    change = opnet.inner_products.rigid_motion_change(kind, base.vertices, base.faces, base_basis.evecs)
    assert change < 1e-10


def test_vertex_normals_in_torch_equal_numpy_and_are_differentiable(targets):
    torch = pytest.importorskip("torch")
    v = np.stack([t.vertices for t in targets])
    faces = targets[0].faces
    x = torch.tensor(v, dtype=torch.float64, requires_grad=True)
    np.testing.assert_allclose(
        opnet.vertex_normals(x, faces).detach().numpy(), opnet.vertex_normals(v, faces), atol=1e-12
    )
    moved = offset_surface(x, faces, 0.02)
    np.testing.assert_allclose(moved.detach().numpy(), offset_surface(v, faces, 0.02), atol=1e-12)
    small = torch.tensor(targets[0].vertices[None], dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda y: opnet.vertex_normals(y, faces), (small,))


def test_the_offset_distance_is_part_of_the_channel_identity():
    assert opnet.channel_digest(OffsetAreaInnerProduct()) == opnet.channel_digest("offset_area")
    assert opnet.channel_digest(OffsetAreaInnerProduct(0.02)) != opnet.channel_digest("offset_area")
    assert opnet.channel_digest(OffsetConformalInnerProduct(0.02)) != opnet.channel_digest(OffsetAreaInnerProduct(0.02))
