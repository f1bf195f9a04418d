"""Shape differences against the paper's formulas (eqs. 1–4, 7–8)."""

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

import opnet

KINDS = opnet.KINDS


def dense_operator(mesh, kind):
    """The n × n operator M of each inner product, built densely from the paper's definitions."""
    a = mesh.mass
    if kind == "area":
        return np.diag(a)
    if kind == "conformal":
        return mesh.stiffness.toarray()
    v = mesh.vertices
    E = ((v[:, None, :] - v[None, :, :]) ** 2).sum(-1) * a[:, None] * a[None, :]
    return np.diag(E.sum(1)) - E  # E^D: off-diagonal -E(i, j), diagonal the row sums


def dense_shape_difference(base_basis, target, kind, p2p):
    """D = K_0⁺ Cᵀ K_i C with C = Φ_iᵀ A_i Π Φ_0 and a full target eigenbasis, all dense."""
    evals_i, phi_i = scipy.linalg.eigh(target.stiffness.toarray(), np.diag(target.mass))
    Pi = np.zeros((target.n_vertices, base_basis.mesh.n_vertices))
    Pi[np.arange(target.n_vertices), p2p] = 1.0
    phi0 = base_basis.evecs
    C = phi_i.T @ np.diag(target.mass) @ Pi @ phi0
    if kind == "area":
        K0, Ki = np.eye(base_basis.k), np.eye(len(evals_i))  # K^{L2} = Id
    elif kind == "conformal":
        K0, Ki = np.diag(base_basis.evals), np.diag(evals_i)  # K^{H1} = Λ
    else:
        K0 = phi0.T @ dense_operator(base_basis.mesh, kind) @ phi0
        Ki = phi_i.T @ dense_operator(target, kind) @ phi_i
    return np.linalg.pinv(K0, rcond=1e-9, hermitian=True) @ C.T @ Ki @ C


def rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


@pytest.mark.parametrize("kind", KINDS)
def test_difference_of_base_with_itself_is_identity(base, base_basis, kind):
    D = opnet.shape_difference(base_basis, base, kind)
    if kind == "area":
        np.testing.assert_allclose(D, np.eye(base_basis.k), atol=1e-12)
    else:  # singular on the constant function: identity on the other modes
        np.testing.assert_allclose(D[1:, 1:], np.eye(base_basis.k - 1), atol=1e-10)
        assert np.abs(D[0]).max() < 1e-10 and np.abs(D[:, 0]).max() < 1e-10


@pytest.mark.parametrize("kind", KINDS)
def test_invariant_to_rigid_motions_of_target(base_basis, targets, kind):
    target = targets[2]
    R = Rotation.random(random_state=1).as_matrix()
    moved = target.with_vertices(target.vertices @ R.T + np.array([3.0, -1.0, 20.0]))
    D = opnet.shape_difference(base_basis, target, kind)
    assert rel(opnet.shape_difference(base_basis, moved, kind), D) < 1e-10
    assert np.abs(D - np.eye(base_basis.k)).max() > 1e-2  # and it does see the deformation


@pytest.mark.parametrize("kind", KINDS)
def test_matches_slow_dense_formula_with_a_permuted_target(base, base_basis, targets, kind):
    """Explicit path with a vertex map, fast path, and the dense paper formula all agree."""
    target = targets[2]
    perm = np.random.default_rng(0).permutation(base.n_vertices)  # target vertex p is base vertex perm[p]
    shuffled = opnet.Mesh(target.vertices[perm], np.argsort(perm)[target.faces])
    dense = dense_shape_difference(base_basis, shuffled, kind, perm)
    fmap = opnet.fmap_from_p2p(base_basis, opnet.eigenbasis(shuffled, shuffled.n_vertices), perm)
    assert rel(opnet.shape_difference(base_basis, shuffled, kind, fmap=fmap), dense) < 1e-8
    assert rel(opnet.shape_difference(base_basis, target, kind), dense) < 1e-8


def test_area_and_conformal_are_the_paper_closed_forms(base_basis, targets):
    """Eq. 3 ``D^A = Cᵀ C`` and eq. 4 ``D^C = Λ_0⁺ Cᵀ Λ_i C``, with a truncated target basis."""
    target_basis = opnet.eigenbasis(targets[0], 80)
    fmap = opnet.identity_fmap(base_basis, target_basis)
    C = fmap.matrix
    D_A = opnet.shape_difference(base_basis, targets[0], "area", fmap=fmap)
    D_C = opnet.shape_difference(base_basis, targets[0], "conformal", fmap=fmap)
    np.testing.assert_allclose(D_A, C.T @ C, atol=1e-10)
    lam0_pinv = np.diag(np.r_[0.0, 1.0 / base_basis.evals[1:]])
    np.testing.assert_allclose(D_C, lam0_pinv @ C.T @ np.diag(target_basis.evals) @ C, atol=1e-8 * np.abs(D_C).max())


@pytest.mark.parametrize("kind", KINDS)
def test_truncated_target_basis_converges_to_full(base_basis, targets, kind):
    fast = opnet.shape_difference(base_basis, targets[1], kind)
    errors = []
    for k_i in (40, 150, targets[1].n_vertices):
        tb = opnet.eigenbasis(targets[1], k_i)
        errors.append(
            rel(opnet.shape_difference(base_basis, targets[1], kind, fmap=opnet.identity_fmap(base_basis, tb)), fast)
        )
    assert errors[2] < 1e-9
    assert errors[1] < errors[0]


def test_soft_map_equals_the_point_map_it_encodes(base_basis, targets):
    tb = opnet.eigenbasis(targets[0], 50)
    p2p = np.random.default_rng(3).integers(0, base_basis.mesh.n_vertices, targets[0].n_vertices)
    P = sp.csr_matrix((np.ones(len(p2p)), (np.arange(len(p2p)), p2p)), shape=(len(p2p), base_basis.mesh.n_vertices))
    hard = opnet.fmap_from_p2p(base_basis, tb, p2p).matrix
    np.testing.assert_allclose(opnet.fmap_from_soft_map(base_basis, tb, P).matrix, hard, atol=1e-13)
    np.testing.assert_allclose(opnet.fmap_from_soft_map(base_basis, tb, P.toarray()).matrix, hard, atol=1e-13)


def test_fmap_transports_functions(base, base_basis, targets):
    """With the identity map and a full target basis, C carries f = Φ0 a to the same vertex values."""
    tb = opnet.eigenbasis(targets[0], targets[0].n_vertices)
    fmap = opnet.identity_fmap(base_basis, tb)
    a = np.random.default_rng(0).normal(size=base_basis.k)
    np.testing.assert_allclose(tb.evecs @ fmap.transfer(a), base_basis.evecs @ a, atol=1e-9)


def test_batched_equals_single(base_basis, targets):
    V = np.stack([t.vertices for t in targets])
    Ds = opnet.shape_differences(base_basis, V, progress=False, batch_size=2)
    assert Ds.shape == (3, 3, base_basis.k, base_basis.k)
    for b, t in enumerate(targets):
        for c, kind in enumerate(KINDS):
            np.testing.assert_allclose(Ds[b, c], opnet.shape_difference(base_basis, t, kind), atol=1e-12)


def test_batches_in_threads_equal_one_batch_and_user_channels_stay_in_this_thread(base_basis, targets):
    import importlib
    import threading

    fast_path = importlib.import_module("opnet.shape_difference").fast_path
    V = np.stack([t.vertices for t in targets] * 3)  # 9 shapes: 5 batches of 2 on the threads
    ips = opnet.inner_products.get_inner_products(KINDS)
    in_threads, one_batch = fast_path(base_basis, V, ips, batch_size=2), fast_path(base_basis, V, ips, batch_size=9)
    np.testing.assert_allclose(in_threads, one_batch, rtol=0, atol=1e-13)  # the products' rounding only
    seen = set()

    class Recorded(opnet.AreaInnerProduct):  # not a built-in type: its project_batch may not be thread-safe
        name = "recorded"

        def project_batch(self, vertices, faces, evecs):
            seen.add(threading.get_ident())
            return super().project_batch(vertices, faces, evecs)

    D = fast_path(base_basis, V, [ips[0], Recorded()], batch_size=2)
    assert seen == {threading.get_ident()}
    np.testing.assert_allclose(D[:, 0], D[:, 1], rtol=0, atol=1e-13)


def test_the_extrinsic_operator_keeps_the_constant_in_its_kernel_far_from_the_origin(base, base_basis):
    K = [
        opnet.inner_products.get_inner_product("extrinsic").project_batch(
            base.vertices[None] + offset, base.faces, base_basis.evecs
        )[0]
        for offset in (0.0, 1e3, 1e6)
    ]
    for moved in K[1:]:  # translation invariant to rounding: the centring's residue Σ a v is kept in the formula
        assert np.abs(moved - K[0]).max() < 1e-9 * np.abs(K[0]).max()


def test_the_blas_comes_back_to_its_threads_after_overlapping_thread_maps():
    import threading

    from threadpoolctl import threadpool_info

    from opnet import _parallel

    before = [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
    started, release = threading.Barrier(2), threading.Event()

    def work(item):
        if item == 0:
            started.wait(timeout=10)
            release.wait(timeout=10)
        return item

    other = threading.Thread(target=lambda: list(_parallel.thread_map(work, range(2), threads=2)))
    other.start()
    started.wait(timeout=10)  # the other map holds the limit; this one starts and ends inside it, and must not
    # restore the threads while the other still runs, nor leave them at one after both
    assert list(_parallel.thread_map(lambda i: i, range(3), threads=2)) == [0, 1, 2]
    release.set()
    other.join()
    assert [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] == before


def test_kept_topology_cannot_be_edited_through_what_callers_get(base):
    edges = opnet.mesh.unique_edges(base.faces)
    edges[0] = 999  # the caller's own copy
    assert opnet.mesh.unique_edges(base.faces)[0, 0] != 999


def test_the_fast_path_names_a_channel_that_returns_nan(base, base_basis):
    import importlib

    fast_path = importlib.import_module("opnet.shape_difference").fast_path
    V = base.vertices[None].copy()
    V[0, base.faces[0]] = V[0, base.faces[0, 0]]  # one face collapsed: its cotangents are undefined
    with pytest.raises(ValueError, match="ConformalInnerProduct.*NaN"), np.errstate(all="ignore"):
        fast_path(base_basis, V, opnet.inner_products.get_inner_products(["conformal"]))


def test_an_instance_that_overrides_its_batch_is_called(base_basis, targets):
    ip = opnet.AreaInnerProduct()
    ip.project_batch = lambda vertices, faces, evecs: np.zeros((len(vertices), evecs.shape[1], evecs.shape[1]))
    assert not opnet.inner_products.is_built_in(ip)
    D = opnet.shape_differences(base_basis, targets[0].vertices[None], channels=[ip], progress=False)
    assert not D.any()


def test_kept_values_follow_the_arrays_contents():
    from opnet import _memo

    built = []
    a = np.arange(6.0)

    def build():
        built.append(1)
        return a * 2

    first = _memo.by_content("test", (a,), build)
    assert _memo.by_content("test", (a.copy(),), build) is first and len(built) == 1  # equal contents: kept
    assert not first.flags.writeable  # a kept value cannot be edited by a caller
    a[0] = 7.0  # edited in place: a new key, built again
    np.testing.assert_array_equal(_memo.by_content("test", (a,), build), a * 2)
    assert len(built) == 2
    assert _memo.by_content("test", (a.astype(np.float32),), build) is not None and len(built) == 3  # dtype counts


def test_a_kept_array_as_a_key_is_hashed_once_and_still_by_its_contents(monkeypatch):
    """A kept value (read-only) that keys another is found by its digest, taken once; equal contents in another
    array give the same key, and a writeable array is hashed every time."""
    from opnet import _memo

    kept = _memo.by_content("test kept", (np.arange(5.0),), lambda: np.arange(7.0) / 6)  # owns its bytes
    hashed = []
    real = _memo.hashlib.blake2b

    def counting(*args, **kwargs):
        hashed.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(_memo.hashlib, "blake2b", counting)
    derived = _memo.by_content("test derived", (kept,), lambda: kept * 3)
    assert _memo.by_content("test derived", (kept,), lambda: None) is derived
    assert len(hashed) == 3  # each call's key, and the new kept value's digest: not the kept key's bytes again
    assert _memo.by_content("test derived", (np.arange(7.0) / 6,), lambda: None) is derived  # same contents
    assert len(hashed) == 5  # the key, and the writeable copy's bytes


def test_gram_tables_give_the_direct_product(base_basis):
    rng = np.random.default_rng(0)
    phi = base_basis.evecs
    for rows in (0, 1, 20):  # none, one product each, the table (built, then kept)
        w = rng.random((rows, phi.shape[0]))
        direct = np.einsum("pi,bp,pj->bij", phi, w, phi)
        for _ in range(2):
            got = opnet._backend.weighted_gram(phi, w)
            assert got.shape == (rows, phi.shape[1], phi.shape[1]) and got.dtype == np.float64
            np.testing.assert_array_equal(got, np.swapaxes(got, -1, -2))  # exactly symmetric
            np.testing.assert_allclose(got, direct, rtol=0, atol=1e-13 * max(np.abs(direct).max(initial=0), 1))


def test_the_number_of_threads_does_not_change_a_bit_of_the_operators(humans):
    """The BLAS sums in an order that depends on its own thread count; every batch runs with one BLAS thread, so a
    collection built with ``OPNET_THREADS=1`` equals one built with two (the extrinsic channel's ``K₀⁺`` amplifies
    a change in the last bit to float32's)."""
    import importlib

    from threadpoolctl import threadpool_info

    if max((p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"), default=1) < 2:
        pytest.skip("the BLAS runs one thread here: nothing to compare")
    fast_path = importlib.import_module("opnet.shape_difference").fast_path
    ips = opnet.inner_products.get_inner_products(KINDS)
    V = humans.vertices[:256].astype(float)
    one, two = (fast_path(humans.base_basis, V, ips, threads=t) for t in (1, 2))
    np.testing.assert_array_equal(one, two)


class GramInnerProduct(opnet.InnerProduct):
    """A user-defined inner product in a few lines: Theorem 1's G = Φᵀ A X Xᵀ A Φ."""

    name = "gram"

    def project(self, vertices, faces, evecs):
        F = evecs.T @ (opnet.vertex_areas(vertices, faces)[:, None] * vertices)
        return F @ F.T


def test_user_defined_inner_product(base, base_basis, targets):
    D = opnet.shape_difference(base_basis, targets[0], GramInnerProduct())
    assert np.linalg.matrix_rank(D, tol=1e-8 * np.abs(D).max()) <= 3
    tb = opnet.eigenbasis(targets[0], targets[0].n_vertices)
    G0 = opnet.gram_matrix(base_basis, base.vertices)
    Gi = opnet.gram_matrix(tb, targets[0].vertices)
    C = opnet.identity_fmap(base_basis, tb).matrix
    np.testing.assert_allclose(D, opnet.pinv_psd(G0) @ C.T @ Gi @ C, atol=1e-8 * np.abs(D).max())
    batch = opnet.shape_differences(
        base_basis, targets[0].vertices[None], channels=[GramInnerProduct()], progress=False
    )
    np.testing.assert_allclose(batch[0, 0], D, atol=1e-12)


def test_bad_inputs_get_clear_errors(base, base_basis, targets):
    with pytest.raises(ValueError, match="unknown channel"):
        opnet.shape_difference(base_basis, targets[0], "volume")
    small = opnet.data.toy.capsule("quick").with_vertices(base.vertices)
    with pytest.raises(ValueError, match="fmap"):
        opnet.shape_difference(
            base_basis,
            opnet.Mesh(
                small.vertices[:-4],
                small.faces[np.all(small.faces < small.n_vertices - 4, axis=1)],
                keep_largest_component=True,
            ),
            "area",
        )
    with pytest.raises(TypeError, match="Eigenbasis"):
        opnet.shape_difference(base.vertices, targets[0], "area")
    other = opnet.eigenbasis(base, 10)
    with pytest.raises(ValueError, match="fmap.source"):
        opnet.shape_difference(
            base_basis, targets[0], "area", fmap=opnet.identity_fmap(other, opnet.eigenbasis(targets[0], 10))
        )
    with pytest.raises(ValueError, match=r"\(B, \d+, 3\)"):
        opnet.shape_differences(base_basis, base.vertices)
    with pytest.raises(TypeError, match="sequence"):
        opnet.shape_differences(base_basis, base.vertices[None], channels="area")
    with pytest.raises(ValueError, match="row-stochastic"):
        opnet.fmap_from_soft_map(base_basis, other, np.ones((base.n_vertices, base.n_vertices)))
    with pytest.raises(ValueError, match="source vertex"):
        opnet.fmap_from_p2p(base_basis, other, np.full(base.n_vertices, base.n_vertices))


def test_distortion_function_finds_the_deformed_region(base, base_basis, targets):
    """The leading eigenfunction of D^A peaks on the bulge (z ≈ -0.6), not on the bent top."""
    D = opnet.shape_difference(base_basis, targets[1], "area")
    f = opnet.distortion_function(D, base_basis)
    z = base.vertices[:, 2]
    assert abs(z[np.argmax(f)] - (-0.6)) < 0.3
    assert np.isclose(np.sum(base.mass * f**2), 1.0)


def test_soft_maps_are_linear_in_the_correspondence(base_basis, targets):
    """A soft map that splits each vertex between two point maps gives the average functional map."""
    tb = opnet.eigenbasis(targets[0], 40)
    n0, n = base_basis.mesh.n_vertices, targets[0].n_vertices
    rng = np.random.default_rng(5)
    p1, p2 = rng.integers(0, n0, n), rng.integers(0, n0, n)
    P = 0.25 * sp.csr_matrix((np.ones(n), (np.arange(n), p1)), shape=(n, n0))
    P = P + 0.75 * sp.csr_matrix((np.ones(n), (np.arange(n), p2)), shape=(n, n0))
    expected = (
        0.25 * opnet.fmap_from_p2p(base_basis, tb, p1).matrix + 0.75 * opnet.fmap_from_p2p(base_basis, tb, p2).matrix
    )
    np.testing.assert_allclose(opnet.fmap_from_soft_map(base_basis, tb, P).matrix, expected, atol=1e-13)


def test_thin_meshes_keep_all_their_modes():
    """A capsule flattened 10⁶× has λ₂/λ_max ~ 6e-10 in a full basis: the pseudo-inverse must not drop real modes."""
    flat = opnet.data.toy.capsule("quick")
    with pytest.warns(opnet.MeshWarning, match="quality"):  # thin triangles, on purpose
        flat = flat.with_vertices(flat.vertices * [1e-6, 1.0, 1.0])
    b = opnet.eigenbasis(flat, flat.n_vertices)
    for kind in opnet.KINDS:
        D = opnet.shape_difference(b, flat, kind)
        np.testing.assert_allclose(D[1:, 1:], np.eye(b.k - 1), atol=1e-5)


def test_batched_path_rejects_bad_shapes_and_batch_sizes(base, base_basis):
    V = np.stack([base.vertices, base.vertices])
    V[1, base.faces[0]] = V[1, base.faces[0, 0]]  # collapse one triangle of shape 1
    with pytest.raises(ValueError, match="shape 1"):
        opnet.shape_differences(base_basis, V)
    for bad in (0, -1, 2.5):
        with pytest.raises(ValueError, match="batch_size"):
            opnet.shape_differences(base_basis, base.vertices[None], batch_size=bad)


def test_functional_maps_are_validated(base_basis):
    with pytest.raises(ValueError, match="k_target, k_source"):
        opnet.FunctionalMap(np.eye(5), base_basis, base_basis)
    with pytest.raises(TypeError, match="Eigenbasis"):
        opnet.FunctionalMap(np.eye(base_basis.k), base_basis, "target")
