"""Maps between triangulations (opnet.matching) and the operators of any mesh through them."""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
import trimesh

import opnet
from opnet import matching
from opnet.data.generators import generate_shapes, resolution_map
from opnet.data.humans import human_faces
from opnet.inner_products import INNER_PRODUCTS


class Gram(opnet.InnerProduct):
    name = "gram"

    def project(self, vertices, faces, evecs):
        F = evecs.T @ (opnet.vertex_areas(vertices, faces)[:, None] * vertices)
        return F @ F.T


def finer_sphere(k=3):
    """A finer triangulation of the 162-vertex test sphere: another mesh of the same shape."""
    s = trimesh.creation.icosphere(k)
    return np.asarray(s.vertices), np.asarray(s.faces)


@pytest.mark.parametrize("kind", [*INNER_PRODUCTS, Gram()])
def test_pull_back_through_the_identity_is_the_fast_path(base_basis, targets, kind):
    ip = opnet.get_inner_product(kind)
    t = targets[2]
    identity = sp.identity(t.n_vertices, format="csr")
    np.testing.assert_allclose(
        ip.pull_back(t.vertices, t.faces, identity, base_basis.evecs),
        ip.project(t.vertices, t.faces, base_basis.evecs),
        rtol=1e-10,
        atol=1e-12,
    )


@pytest.mark.parametrize("kind", ["conformal", Gram()])
def test_default_pull_back_is_the_papers_formula_with_a_full_target_basis(small_shapes, kind):
    """(PΦ)ᵀ M (PΦ) = Cᵀ K_i C with C = Φ_iᵀ A_i P Φ_0 and the target's full eigenbasis (slow, dense)."""
    base, _ = small_shapes
    basis = opnet.eigenbasis(base, 20)
    v, f = finer_sphere()
    target = opnet.Mesh(v * np.array([1.2, 1.0, 0.9]), f)
    P = opnet.matching.closest_point_map(basis, opnet.Mesh(v, f)).to_base
    full = opnet.eigenbasis(target, target.n_vertices)
    C = full.evecs.T @ (full.mass[:, None] * (P @ basis.evecs))
    ip = opnet.get_inner_product(kind)
    slow = C.T @ ip.project(target.vertices, target.faces, full.evecs) @ C
    np.testing.assert_allclose(
        ip.pull_back(target.vertices, target.faces, P, basis.evecs), slow, rtol=1e-7, atol=1e-9 * np.abs(slow).max()
    )


def test_encode_with_the_base_triangulation_or_a_vertex_map_is_the_fast_path(base, base_basis, targets):
    fast = opnet.shape_differences(base_basis, np.stack([t.vertices for t in targets]))
    tol = dict(rtol=1e-9, atol=1e-12 * np.abs(fast).max())
    for t, expected in zip(targets, fast):
        np.testing.assert_allclose(opnet.encode(t, base_basis), expected, **tol)
        np.testing.assert_allclose(opnet.encode(t, base_basis, fmap=np.arange(t.n_vertices)), expected, **tol)
    np.testing.assert_allclose(opnet.encode(targets[0], base_basis, channels=("extrinsic",)), fast[0, 2:], **tol)


def test_a_finer_triangulation_of_the_base_gives_nearly_the_identity(small_shapes):
    """The true map of another triangulation of the same sphere: the lumped area and extrinsic differences are
    nearly those of the base with itself (the identity, but for the extrinsic's constant mode)."""
    base, _ = small_shapes
    basis = opnet.eigenbasis(base, 10)
    fine = opnet.Mesh(*finer_sphere())
    D = opnet.encode(fine, basis, fmap=opnet.matching.closest_point_map(basis, fine))
    itself = opnet.encode(base, basis)
    for c in range(3):
        assert np.abs(D[c] - itself[c]).max() < 0.05, c


@pytest.fixture(scope="module")
def bodies_2k(humans):
    """The base body at 2k vertices (another triangulation of the 1k base), and one posed test body at 2k."""
    i = humans.indices("test")[0]
    posed = generate_shapes(humans, humans.params["phenotypes"][[i]], humans.params["controls"][[i]], resolution="2k")
    return opnet.Mesh(posed[0], human_faces("2k")), resolution_map(humans, "2k"), i


def test_computed_map_of_a_posed_2k_body_is_right_and_not_mirrored(humans, bodies_2k):
    mesh, truth, _ = bodies_2k
    # a rigid motion and another vertex order: nothing of the generator's correspondence is left
    rot = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    rot *= np.sign(np.linalg.det(rot))
    order = np.random.default_rng(1).permutation(mesh.n_vertices)
    moved = opnet.Mesh(mesh.vertices[order] @ rot.T + 0.3, np.argsort(order)[mesh.faces])
    computed = opnet.compute_map(humans.base_basis, moved)
    true_map = opnet.SurfaceMap(humans.base_basis, moved, truth[order])
    err = computed.error(true_map)
    # the mirror image of the true map: x → −x on the (left–right symmetric) base
    mirror_points = true_map.points * np.array([-1, 1, 1])
    mirror_err = np.linalg.norm(computed.points - mirror_points, axis=1) / np.sqrt(humans.base_basis.mesh.area)
    assert err.mean() < 0.02, err.mean()  # ≈ 1.3 cm on a 1.8 m² body
    assert mirror_err.mean() > 5 * err.mean()
    q = computed.quality()
    assert q["coverage"] > 0.95 and q["orientation"] > 0.8, q


def test_computed_map_ignores_scale_and_face_orientation_and_ends_at_k(humans, bodies_2k):
    mesh, truth, _ = bodies_2k
    reference = opnet.compute_map(humans.base_basis, mesh, k=50)
    assert reference.fmap.shape == (50, 50)  # 50 - 20 is not a multiple of ZoomOut's step of 4
    for other in (opnet.Mesh(mesh.vertices * 1000, mesh.faces), opnet.Mesh(mesh.vertices, mesh.faces[:, ::-1])):
        sm = opnet.compute_map(humans.base_basis, other, k=50)
        np.testing.assert_allclose(sm.points, reference.points, atol=1e-6)
        assert sm.quality()["orientation"] > 0.8


def test_quality_flags_mirrored_and_collapsed_maps(humans):
    basis = humans.base_basis
    base = basis.mesh
    mirrored = opnet.matching.closest_point_map(basis, base.with_vertices(base.vertices * np.array([-1, 1, 1])))
    mirrored = opnet.SurfaceMap(basis, base, mirrored.to_base)  # each vertex onto its mirror point
    good = opnet.matching.closest_point_map(basis, base)
    assert good.quality()["orientation"] > 0.99 and good.quality()["coverage"] > 0.99
    assert mirrored.quality()["orientation"] < 0.1
    assert mirrored.quality()["coverage"] > 0.95  # a mirror map is not a collapse
    few = opnet.matching.map_from_p2p(basis, base, np.arange(base.n_vertices) % 7)
    assert few.quality()["coverage"] < 0.5


def test_encode_warns_when_the_computed_map_looks_wrong(humans, monkeypatch):
    basis = humans.base_basis
    base = basis.mesh
    collapsed = opnet.matching.map_from_p2p(basis, base, np.zeros(base.n_vertices, dtype=int))
    monkeypatch.setattr(matching, "compute_map", lambda *a, **k: collapsed)
    with pytest.warns(opnet.matching.MapQualityWarning, match="collapses"):
        matching.encode(base, basis, fmap="computed")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        matching.encode(base, basis, fmap="computed", warn=False)


def test_bad_input_gets_errors_that_say_what_to_do(small_shapes):
    sphere, _ = small_shapes
    basis = opnet.eigenbasis(sphere, 10)
    fine = opnet.Mesh(*finer_sphere())
    with pytest.raises(ValueError, match="fmap='computed'"):
        opnet.encode(fine, basis)
    with pytest.raises(TypeError, match="opnet.Mesh"):
        opnet.encode(fine.vertices, basis)
    with pytest.raises(TypeError, match="only to fmap='computed'"):
        opnet.encode(sphere, basis, fmap=np.arange(sphere.n_vertices), k=50)
    with pytest.raises(ValueError, match="integer array of shape"):
        opnet.encode(fine, basis, fmap=np.zeros(3, dtype=int))
    with pytest.raises(ValueError, match="None, 'computed'"):
        opnet.encode(fine, basis, fmap="nearest")
    half = opnet.Mesh(
        fine.vertices, fine.faces[fine.vertices[fine.faces].mean(1)[:, 2] > 0], keep_largest_component=True
    )
    with pytest.raises(ValueError, match="boundary edges"):
        opnet.compute_map(basis, half)
    with pytest.raises(ValueError, match="k_init"):
        opnet.compute_map(basis, fine, k=10, k_init=20)
    with pytest.raises(ValueError, match="another mesh"):
        opnet.encode(fine, basis, fmap=opnet.matching.closest_point_map(basis, sphere))
    with pytest.raises(TypeError, match="not an opnet.FunctionalMap"):
        opnet.encode(sphere, basis, fmap=opnet.identity_fmap(basis, basis))
    with pytest.raises(ValueError, match="channels is empty"):
        opnet.matching.operators_through_map(opnet.matching.closest_point_map(basis, fine), ())
    with pytest.raises(ValueError, match="to_base must be"):
        opnet.SurfaceMap(basis, fine, np.eye(3))
    with pytest.raises(TypeError, match="non-empty list"):
        opnet.matching.operators_through_map([])
    other = opnet.eigenbasis(sphere, basis.k)
    with pytest.raises(ValueError, match="different bases"):
        opnet.matching.operators_through_map(
            [opnet.matching.closest_point_map(basis, fine), opnet.matching.closest_point_map(other, fine)]
        )


def test_operators_through_a_list_of_maps_equal_one_at_a_time(small_shapes):
    sphere, deformed = small_shapes
    basis = opnet.eigenbasis(sphere, 20)
    maps = [opnet.matching.closest_point_map(basis, m) for m in deformed]
    batch = opnet.matching.operators_through_map(maps)
    assert batch.shape == (len(maps), len(opnet.KINDS), 20, 20)
    for D, sm in zip(batch, maps):
        np.testing.assert_array_equal(D, opnet.matching.operators_through_map(sm))


@pytest.mark.slow
def test_closest_points_on_faces_matches_brute_force(small_shapes):
    sphere, _ = small_shapes
    rng = np.random.default_rng(0)
    points = rng.normal(size=(300, 3)) * rng.uniform(0.5, 1.5, (300, 1))
    near = np.argsort(np.linalg.norm(points[:, None] - sphere.vertices[None], axis=2), axis=1)[:, :3]
    face, bary = opnet.mesh.closest_points_on_faces(points, sphere.vertices, sphere.faces, near)
    found = np.einsum("mj,mjd->md", bary, sphere.vertices[sphere.faces[face]])
    assert np.all(bary >= -1e-12) and np.allclose(bary.sum(1), 1)
    # brute force: a dense sampling of every face's barycentric triangle
    u = np.linspace(0, 1, 41)
    s, t = np.meshgrid(u, u)
    keep = s + t <= 1
    w = np.stack([1 - s[keep] - t[keep], s[keep], t[keep]], 1)
    samples = np.einsum("sj,fjd->fsd", w, sphere.vertices[sphere.faces]).reshape(-1, 3)
    best = np.sqrt(((points[:, None] - samples[None]) ** 2).sum(-1).min(1))
    got = np.linalg.norm(points - found, axis=1)
    assert np.all(got <= best + 1e-12)  # never further than any sample
    assert np.all(got >= best - 0.02)  # and as close as the sampling resolves


def test_decode_accepts_one_or_many_and_picks_the_networks_channels(humans):
    torch = pytest.importorskip("torch")
    torch.manual_seed(0)
    net = opnet.OperatorNet(humans.vertices.shape[1], k=60, channels=("extrinsic",))
    ops = humans.operators[:3].astype(np.float64)
    many = opnet.decode(net, ops, opnet.KINDS)
    assert many.shape == (3, humans.vertices.shape[1], 3) and many.dtype == np.float64
    np.testing.assert_allclose(opnet.decode(net, ops[1], opnet.KINDS), many[1], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(opnet.decode(net, ops[:, 2:]), many, rtol=1e-5, atol=1e-6)  # the network's channels
    with pytest.raises(ValueError, match=r"C = 1 channels \('extrinsic',\) \(the network's channels"):
        opnet.decode(net, ops)
    with pytest.raises(ValueError, match="C = 3 channels"):
        opnet.decode(net, ops[:, :2], opnet.KINDS)
    with pytest.raises(ValueError, match="do not hold"):
        opnet.decode(net, ops[:, :2], channels=("area", "conformal"))
    with pytest.raises(TypeError, match="OperatorNet"):
        opnet.decode("net", ops)
    with pytest.raises(TypeError, match="not a single one"):
        opnet.decode(net, ops[:, 2:], channels="extrinsic")
    bad = ops.copy()
    bad[0, 0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        opnet.decode(net, bad, opnet.KINDS)
