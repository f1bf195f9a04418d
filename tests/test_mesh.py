"""Tests for opnet.Mesh, opnet.MeshError and opnet.load_mesh."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import trimesh
from scipy.spatial import cKDTree

import opnet
from opnet.data import toy
from opnet.mesh import face_areas

# ---------------------------------------------------------------------------------------------
# small meshes
# ---------------------------------------------------------------------------------------------

TET_V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
TET_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def tet_area() -> float:
    # three right isosceles triangles with legs 1, plus one equilateral with side sqrt(2)
    return 3 * 0.5 + np.sqrt(3) / 4 * 2


def icosphere(subdiv: int = 2) -> tuple[np.ndarray, np.ndarray]:
    tm = trimesh.creation.icosphere(subdiv)
    return np.array(tm.vertices), np.array(tm.faces)


def shuffled_icosphere(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """An icosphere with a random vertex order, so that 'order preserved' means something."""
    v, f = icosphere(2)
    perm = np.random.default_rng(seed).permutation(len(v))
    inv = np.argsort(perm)
    return v[perm], inv[f]


def two_tetrahedra() -> tuple[np.ndarray, np.ndarray]:
    v = np.vstack([TET_V, TET_V + [5.0, 0.0, 0.0]])
    f = np.vstack([TET_F, TET_F + 4])
    return v, f


# ---------------------------------------------------------------------------------------------
# valid construction
# ---------------------------------------------------------------------------------------------


def test_tetrahedron_basic_properties():
    m = opnet.Mesh(TET_V, TET_F)
    assert m.n_vertices == 4 and m.n_faces == 4
    np.testing.assert_array_equal(m.vertices, TET_V)
    np.testing.assert_array_equal(m.faces, TET_F)
    np.testing.assert_array_equal(m.kept_vertices, np.arange(4))
    assert m.area == pytest.approx(tet_area(), rel=1e-12)
    assert "n_vertices=4" in repr(m)


def test_dtypes_are_float64_and_int64():
    # int32 coordinates and int32 faces are accepted and converted
    m = opnet.Mesh(TET_V.astype(np.int32), TET_F.astype(np.int32))
    assert m.vertices.dtype == np.float64
    assert m.faces.dtype == np.int64
    assert m.kept_vertices.dtype.kind == "i"
    # float faces holding whole numbers are accepted too
    m2 = opnet.Mesh(TET_V.astype(np.float32), TET_F.astype(np.float64))
    assert m2.vertices.dtype == np.float64 and m2.faces.dtype == np.int64
    np.testing.assert_array_equal(m2.faces, TET_F)
    # python lists work
    m3 = opnet.Mesh(TET_V.tolist(), TET_F.tolist())
    np.testing.assert_array_equal(m3.vertices, TET_V)


@pytest.mark.parametrize("attr", ["vertices", "faces", "kept_vertices"])
def test_arrays_are_read_only(attr):
    m = opnet.Mesh(TET_V, TET_F)
    arr = getattr(m, attr)
    assert not arr.flags.writeable
    with pytest.raises(ValueError):
        arr[0] = 7
    # still the original values
    assert arr[0].tolist() == getattr(opnet.Mesh(TET_V, TET_F), attr)[0].tolist()


def test_mass_is_read_only():
    """mesh.mass is cached and shared (e.g. as Eigenbasis.mass): writing to it in place would
    silently change mesh.area and every later operator built on the mesh."""
    m = opnet.Mesh(TET_V, TET_F)
    area = m.area
    assert not m.mass.flags.writeable
    with pytest.raises(ValueError):
        m.mass[0] = 0.0
    assert m.area == area


def test_input_arrays_are_copied():
    v, f = TET_V.copy(), TET_F.copy()
    m = opnet.Mesh(v, f)
    v[0] = 99.0
    f[0] = [3, 2, 1]
    np.testing.assert_array_equal(m.vertices, TET_V)
    np.testing.assert_array_equal(m.faces, TET_F)
    assert v.flags.writeable and f.flags.writeable  # the caller's arrays are left writable


def test_with_vertices_keeps_faces_and_validates():
    m = opnet.Mesh(TET_V, TET_F)
    m2 = m.with_vertices(2.0 * TET_V)
    np.testing.assert_array_equal(m2.faces, m.faces)
    assert m2.area == pytest.approx(4.0 * m.area, rel=1e-12)
    with pytest.raises(opnet.MeshError, match="NaN"):
        m.with_vertices(np.full((4, 3), np.nan))


# ---------------------------------------------------------------------------------------------
# bad input -> MeshError naming the problem
# ---------------------------------------------------------------------------------------------


def _with(v_changes=None, f=None):
    v = TET_V.copy()
    if v_changes:
        for i, row in v_changes.items():
            v[i] = row
    return v, TET_F if f is None else f


def test_nan_coordinates():
    v, f = _with({2: [0.0, np.nan, 0.0]})
    with pytest.raises(opnet.MeshError, match="NaN") as exc:
        opnet.Mesh(v, f)
    assert "vertex 2" in str(exc.value)


@pytest.mark.parametrize("value", [np.inf, -np.inf])
def test_inf_coordinates(value):
    v, f = _with({1: [value, 0.0, 0.0]})
    with pytest.raises(opnet.MeshError, match="infinite") as exc:
        opnet.Mesh(v, f)
    assert "vertex 1" in str(exc.value)


@pytest.mark.parametrize(
    "vertices",
    [
        TET_V[:, :2],  # (n, 2)
        TET_V.ravel(),  # 1-d
        TET_V[None],  # (1, n, 3)
        np.hstack([TET_V, np.ones((4, 1))]),  # (n, 4)
    ],
    ids=["n-by-2", "1-d", "3-d", "n-by-4"],
)
def test_vertices_wrong_shape(vertices):
    with pytest.raises(opnet.MeshError, match="shape"):
        opnet.Mesh(vertices, TET_F)


@pytest.mark.parametrize(
    "vertices",
    [
        TET_V.astype(str),
        TET_V.astype(object),
        np.array([["a", "b", "c"]] * 4),
        TET_V.astype(complex),
        TET_V.astype(bool),
    ],
    ids=["numeric-strings", "object", "letters", "complex", "bool"],
)
def test_vertices_non_numeric_dtype(vertices):
    with pytest.raises(opnet.MeshError, match="real array|complex"):
        opnet.Mesh(vertices, TET_F)


def test_vertices_ragged():
    with pytest.raises(opnet.MeshError, match="vertices"):
        opnet.Mesh([[0, 0, 0], [1, 0], [0, 1, 0], [0, 0, 1]], TET_F)


@pytest.mark.parametrize(
    "faces",
    [
        TET_F[:, :2],  # (m, 2)
        TET_F.ravel(),  # 1-d
        np.hstack([TET_F, TET_F[:, :1]]),  # quads
        TET_F[None],  # 3-d
    ],
    ids=["m-by-2", "1-d", "quads", "3-d"],
)
def test_faces_wrong_shape(faces):
    with pytest.raises(opnet.MeshError, match="shape"):
        opnet.Mesh(TET_V, faces)


def test_faces_ragged_polygon_list():
    """A list mixing a triangle and a quad is a wrong-shape faces input, not a numpy crash."""
    with pytest.raises(opnet.MeshError, match="faces"):
        opnet.Mesh(TET_V, [[0, 2, 1], [0, 1, 3, 2]])


def test_faces_empty():
    with pytest.raises(opnet.MeshError, match="no faces"):
        opnet.Mesh(TET_V, np.zeros((0, 3), dtype=int))


@pytest.mark.parametrize("bad", [0.5, np.nan, np.inf])
def test_float_faces_with_non_integer_values(bad):
    f = TET_F.astype(float)
    f[1, 2] = bad
    with pytest.raises(opnet.MeshError, match="non-integer"):
        opnet.Mesh(TET_V, f)


@pytest.mark.parametrize(
    "faces", [TET_F.astype(str), TET_F.astype(bool), TET_F.astype(complex)], ids=["str", "bool", "complex"]
)
def test_faces_non_integer_dtype(faces):
    with pytest.raises(opnet.MeshError, match="dtype"):
        opnet.Mesh(TET_V, faces)


@pytest.mark.parametrize("bad_index", [-1, 4, 100])
def test_face_index_out_of_range(bad_index):
    f = TET_F.copy()
    f[3, 1] = bad_index
    with pytest.raises(opnet.MeshError, match=r"must lie in \[0, 3\]"):
        opnet.Mesh(TET_V, f)


def test_one_based_faces_are_out_of_range():
    with pytest.raises(opnet.MeshError, match="1-based"):
        opnet.Mesh(TET_V, TET_F + 1)


def test_face_repeating_a_vertex():
    f = np.vstack([TET_F, [[0, 0, 1]]])
    with pytest.raises(opnet.MeshError, match="repeat") as exc:
        opnet.Mesh(TET_V, f)
    assert "face 4" in str(exc.value)


def test_zero_area_face_collinear_vertices():
    # a triangulated square pyramid whose base has a vertex on the middle of one edge:
    # vertex 4 lies on the segment 0-1, so face (0, 4, 1) is a zero-area sliver
    v = np.array([[0.0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [1, 0, 0], [1, 1, 1]])
    f = np.array([[0, 4, 1], [0, 1, 2], [0, 2, 3], [0, 5, 4], [4, 5, 1], [1, 5, 2], [2, 5, 3], [3, 5, 0]])
    assert face_areas(v, f)[0] == 0.0
    with pytest.raises(opnet.MeshError, match="zero area") as exc:
        opnet.Mesh(v, f)
    assert "face 0" in str(exc.value)


def test_zero_area_face_is_scale_invariant():
    # the same sliver mesh scaled to a micrometre is still rejected, and a good mesh
    # scaled to a micrometre is still accepted
    v = np.array([[0.0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0], [1, 0, 0], [1, 1, 1]])
    f = np.array([[0, 4, 1], [0, 1, 2], [0, 2, 3], [0, 5, 4], [4, 5, 1], [1, 5, 2], [2, 5, 3], [3, 5, 0]])
    with pytest.raises(opnet.MeshError, match="zero area"):
        opnet.Mesh(1e-6 * v, f)
    vs, fs = icosphere(2)
    m = opnet.Mesh(1e-6 * vs, fs)
    assert m.area == pytest.approx(1e-12 * opnet.Mesh(vs, fs).area, rel=1e-10)


def test_non_manifold_edge():
    # three triangles hinged on the edge 0-1
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0.3], [0.5, 0, 1]])
    f = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4]])
    with pytest.raises(opnet.MeshError, match="non-manifold"):
        opnet.Mesh(v, f)


def test_duplicate_face_is_non_manifold():
    with pytest.raises(opnet.MeshError, match="non-manifold"):
        opnet.Mesh(TET_V, np.vstack([TET_F, TET_F[:1]]))


def test_two_components():
    v, f = two_tetrahedra()
    with pytest.raises(opnet.MeshError, match="2 connected components") as exc:
        opnet.Mesh(v, f)
    assert "keep_largest_component" in str(exc.value)


def test_unused_vertices():
    v = np.vstack([TET_V, [[3.0, 3.0, 3.0], [4.0, 4.0, 4.0]]])
    with pytest.raises(opnet.MeshError, match="used by no face") as exc:
        opnet.Mesh(v, TET_F)
    assert "2 of them" in str(exc.value)
    assert "3 connected components" in str(exc.value)


@pytest.mark.parametrize("n", [0, 1, 3])
def test_fewer_than_four_vertices(n):
    v = TET_V[:n]
    f = np.array([[0, 1, 2]]) if n == 3 else np.zeros((0, 3), dtype=int)
    with pytest.raises(opnet.MeshError, match="at least 4"):
        opnet.Mesh(v, f)


def test_mesh_error_is_a_value_error():
    assert issubclass(opnet.MeshError, ValueError)


# ---------------------------------------------------------------------------------------------
# keep_largest_component
# ---------------------------------------------------------------------------------------------


def test_keep_largest_component_maps_back_to_input():
    vs, fs = icosphere(1)  # 42 vertices
    vt, ft = TET_V + [5.0, 0.0, 0.0], TET_F
    # interleave: tetrahedron first, an unused vertex, then the sphere, another unused vertex,
    # then shuffle all vertex indices
    v = np.vstack([vt, [[9.0, 9.0, 9.0]], vs, [[-9.0, 0.0, 0.0]]])
    f = np.vstack([ft, fs + 5])
    perm = np.random.default_rng(3).permutation(len(v))
    inv = np.argsort(perm)
    v, f = v[perm], inv[f]
    sphere_in = np.sort(inv[np.arange(5, 47)])  # input indices of the sphere vertices

    m = opnet.Mesh(v, f, keep_largest_component=True)
    assert m.n_vertices == 42 and m.n_faces == len(fs)
    np.testing.assert_array_equal(np.sort(m.kept_vertices), sphere_in)
    np.testing.assert_array_equal(m.vertices, v[m.kept_vertices])
    # faces are valid indices of the new mesh and describe the same triangles as the input
    assert m.faces.min() == 0 and m.faces.max() == 41
    back = m.kept_vertices[m.faces]
    sphere_faces_in = f[np.isin(f[:, 0], sphere_in)]
    assert {tuple(r) for r in back} == {tuple(r) for r in sphere_faces_in}
    assert m.area == pytest.approx(trimesh.Trimesh(vs, fs, process=False).area, rel=1e-12)
    assert not m.kept_vertices.flags.writeable


def test_keep_largest_component_only_unused_vertices():
    v = np.vstack([[[7.0, 7.0, 7.0]], TET_V])
    m = opnet.Mesh(v, TET_F + 1, keep_largest_component=True)
    np.testing.assert_array_equal(m.kept_vertices, [1, 2, 3, 4])
    np.testing.assert_array_equal(m.vertices, TET_V)
    np.testing.assert_array_equal(m.faces, TET_F)


def test_keep_largest_component_noop_when_connected():
    v, f = icosphere(1)
    m = opnet.Mesh(v, f, keep_largest_component=True)
    np.testing.assert_array_equal(m.kept_vertices, np.arange(len(v)))
    np.testing.assert_array_equal(m.faces, f)


def test_keep_largest_component_too_small():
    # two disjoint triangles: the largest component has 3 vertices
    v = np.vstack([TET_V[:3], TET_V[:3] + 5.0])
    f = np.array([[0, 1, 2], [3, 4, 5]])
    with pytest.raises(opnet.MeshError, match="at least 4"):
        opnet.Mesh(v, f, keep_largest_component=True)


# ---------------------------------------------------------------------------------------------
# normalize_area
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("scale", [1e-3, 1.0, 250.0])
def test_normalize_area(scale):
    v, f = shuffled_icosphere()
    v = scale * (v + [3.0, -1.0, 2.0])
    v[:, 0] *= 1.7  # an ellipsoid, away from the origin
    m = opnet.Mesh(v, f, normalize_area=True)
    assert m.area == pytest.approx(1.0, rel=1e-12)
    assert face_areas(m.vertices, m.faces).sum() == pytest.approx(1.0, rel=1e-12)
    centroid = (m.mass[:, None] * m.vertices).sum(0) / m.mass.sum()
    np.testing.assert_allclose(centroid, 0.0, atol=1e-12)
    # a similarity transform of the input: same shape, same faces
    raw = opnet.Mesh(v, f)
    c_raw = (raw.mass[:, None] * raw.vertices).sum(0) / raw.area
    np.testing.assert_allclose(m.vertices, (v - c_raw) / np.sqrt(raw.area), atol=1e-12)
    np.testing.assert_array_equal(m.faces, f)
    assert not m.vertices.flags.writeable


def test_normalize_area_with_keep_largest_component():
    v, f = two_tetrahedra()
    v = np.vstack([v, TET_V * 3.0 + 20.0, [[1.0, 1.0, 1.0]]])
    f = np.vstack([f, TET_F + 8])
    # three 4-vertex tetrahedra (one scaled by 3) and an unused vertex: any kept tetrahedron
    # is rescaled to unit area
    m = opnet.Mesh(v, f, keep_largest_component=True, normalize_area=True)
    assert m.n_vertices == 4
    assert m.area == pytest.approx(1.0, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# operators
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def meshes():
    v, f = icosphere(2)
    sphere = opnet.Mesh(v, f)
    caps = toy.capsule("quick")
    base, target = toy.finger_pair("quick")
    return {"tet": opnet.Mesh(TET_V, TET_F), "sphere": sphere, "capsule": caps, "target": target}


@pytest.mark.parametrize("name", ["tet", "sphere", "capsule", "target"])
def test_stiffness_symmetric_psd_zero_row_sums(meshes, name):
    m = meshes[name]
    W = m.stiffness
    assert sp.issparse(W) and W.shape == (m.n_vertices, m.n_vertices)
    Wd = W.toarray()
    scale = np.abs(Wd).max()
    assert scale > 0
    np.testing.assert_allclose(Wd, Wd.T, atol=1e-12 * scale)
    np.testing.assert_allclose(Wd.sum(axis=1), 0.0, atol=1e-10 * scale)
    ev = np.linalg.eigvalsh(Wd)
    assert ev.min() >= -1e-10 * ev.max()
    # connected mesh: exactly one (numerically) zero eigenvalue
    assert ev[1] > 1e-6 * ev.max()
    # diagonal positive, off-diagonals are minus the edge weights
    assert (np.diag(Wd) > 0).all()


def test_stiffness_of_regular_tetrahedron_is_known():
    # regular tetrahedron: every angle 60 deg, w_ij = (cot 60 + cot 60)/2 = 1/sqrt(3)
    v = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    m = opnet.Mesh(v, TET_F)
    w = 1 / np.sqrt(3)
    expected = -w * (np.ones((4, 4)) - np.eye(4)) + 3 * w * np.eye(4)
    np.testing.assert_allclose(m.stiffness.toarray(), expected, rtol=1e-12)


@pytest.mark.parametrize("name", ["tet", "sphere", "capsule", "target"])
def test_mass_sums_to_total_area(meshes, name):
    m = meshes[name]
    true_area = trimesh.Trimesh(m.vertices, m.faces, process=False).area
    assert m.mass.shape == (m.n_vertices,)
    assert (m.mass > 0).all()
    assert m.mass.sum() == pytest.approx(true_area, rel=1e-12)
    assert m.area == pytest.approx(true_area, rel=1e-12)
    # barycentric: a third of each incident face's area
    fa = face_areas(m.vertices, m.faces)
    expected = np.bincount(m.faces.ravel(), weights=np.repeat(fa / 3, 3), minlength=m.n_vertices)
    np.testing.assert_allclose(m.mass, expected, rtol=1e-12)


# ---------------------------------------------------------------------------------------------
# load_mesh
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("ext", [".ply", ".obj", ".off"])
def test_load_mesh_round_trip_preserves_order(tmp_path, ext):
    v, f = shuffled_icosphere(seed=1)
    path = tmp_path / f"sphere{ext}"
    trimesh.Trimesh(v, f, process=False).export(path)
    m = opnet.load_mesh(path)
    assert isinstance(m, opnet.Mesh)
    assert m.n_vertices == len(v) and m.n_faces == len(f)
    # formats store float32 or limited decimal digits
    np.testing.assert_allclose(m.vertices, v, atol=1e-6)
    np.testing.assert_array_equal(m.faces, f)
    # str paths and upper-case extensions work too
    upper = tmp_path / f"SPHERE{ext.upper()}"
    upper.write_bytes(path.read_bytes())
    m2 = opnet.load_mesh(str(upper))
    np.testing.assert_array_equal(m2.vertices, m.vertices)


def test_load_mesh_capsule_obj(tmp_path):
    caps = toy.capsule("quick")
    path = tmp_path / "capsule.obj"
    trimesh.Trimesh(caps.vertices, caps.faces, process=False).export(path)
    m = opnet.load_mesh(path)
    np.testing.assert_allclose(m.vertices, caps.vertices, atol=1e-6)
    np.testing.assert_array_equal(m.faces, caps.faces)
    assert m.area == pytest.approx(caps.area, rel=1e-6)


def test_load_mesh_stl(tmp_path):
    """STL stores a triangle soup (3 vertices per face); loading must rebuild the shared vertices.

    The vertex order cannot survive STL, but the surface must: the same number of vertices,
    the same vertex positions (as a set) and the same area.
    """
    v, f = icosphere(2)
    path = tmp_path / "sphere.stl"
    trimesh.Trimesh(v, f, process=False).export(path)
    m = opnet.load_mesh(path)
    assert m.n_vertices == len(v)
    assert m.n_faces == len(f)
    assert m.area == pytest.approx(opnet.Mesh(v, f).area, rel=1e-6)
    dist, _ = cKDTree(v).query(m.vertices)
    assert dist.max() < 1e-6


def test_load_mesh_kwargs_are_passed(tmp_path):
    v, f = shuffled_icosphere()
    path = tmp_path / "s.ply"
    trimesh.Trimesh(3.0 * v + 1.0, f, process=False).export(path)
    m = opnet.load_mesh(path, normalize_area=True)
    assert m.area == pytest.approx(1.0, rel=1e-12)


def test_load_mesh_keep_largest_component(tmp_path):
    # first component: a tetrahedron (4 vertices); second: a tetrahedron with one face
    # split into three around its centroid (5 vertices), which is the largest
    v1 = np.vstack([TET_V, TET_V[[1, 2, 3]].mean(0, keepdims=True)])
    f1 = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 4], [2, 3, 4], [3, 1, 4]])
    v = np.vstack([TET_V + 5.0, v1])
    f = np.vstack([TET_F, f1 + 4])
    path = tmp_path / "two.off"
    trimesh.Trimesh(v, f, process=False).export(path)
    with pytest.raises(opnet.MeshError, match="connected components"):
        opnet.load_mesh(path)
    m = opnet.load_mesh(path, keep_largest_component=True)
    np.testing.assert_array_equal(m.kept_vertices, np.arange(4, 9))
    np.testing.assert_allclose(m.vertices, v1, atol=1e-9)


def test_load_mesh_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no mesh file"):
        opnet.load_mesh(tmp_path / "nothing.ply")


def test_load_mesh_unsupported_extension(tmp_path):
    path = tmp_path / "cloud.xyz"
    path.write_text("0 0 0\n1 0 0\n0 1 0\n")
    with pytest.raises(opnet.MeshError, match="supported formats"):
        opnet.load_mesh(path)
    # unsupported even when the file does not exist
    with pytest.raises(opnet.MeshError, match=r"\.xyz"):
        opnet.load_mesh(tmp_path / "missing.xyz")


def test_load_mesh_point_cloud(tmp_path):
    path = tmp_path / "cloud.ply"
    trimesh.PointCloud(np.random.default_rng(0).random((10, 3))).export(path)
    with pytest.raises(opnet.MeshError, match="no triangles"):
        opnet.load_mesh(path)


def test_load_mesh_garbage_file(tmp_path):
    path = tmp_path / "bad.off"
    path.write_text("OFF\n3 1 0\n0 0 0\n1 0\nxx\n")
    with pytest.raises(opnet.MeshError):
        opnet.load_mesh(path)


def test_load_mesh_validates(tmp_path):
    # a file holding a non-manifold mesh is rejected by the same checks as Mesh()
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0.3], [0.5, 0, 1]])
    f = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4]])
    path = tmp_path / "fin.ply"
    trimesh.Trimesh(v, f, process=False).export(path)
    with pytest.raises(opnet.MeshError, match="non-manifold"):
        opnet.load_mesh(path)


def test_load_obj_with_texture_seams_keeps_vertex_order(tmp_path):
    """trimesh splits vertices at UV seams unless told to keep the file's order."""
    sphere = trimesh.creation.icosphere(1)
    lines = [f"v {x} {y} {z}" for x, y, z in sphere.vertices]
    lines += [f"vt {u} {v}" for u, v in np.random.default_rng(0).random((3 * len(sphere.faces), 2))]
    lines += [
        f"f {a + 1}/{3 * i + 1} {b + 1}/{3 * i + 2} {c + 1}/{3 * i + 3}" for i, (a, b, c) in enumerate(sphere.faces)
    ]
    path = tmp_path / "uv.obj"
    path.write_text("\n".join(lines) + "\n")
    mesh = opnet.load_mesh(path)
    np.testing.assert_allclose(mesh.vertices, sphere.vertices)
    np.testing.assert_array_equal(mesh.faces, sphere.faces)
