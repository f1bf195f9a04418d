"""Bad input across the public API gets an error of opnet's own, at the call the user made, naming the argument,
what it got and what to do (issue 8's classes: near-degenerate geometry, shape mismatches, types, user-defined
inner products, non-finite values, empty batches). Storage is tested in test_collections, the documentation's
code blocks in test_docs."""

import importlib
import importlib.util
import warnings

import numpy as np
import pytest
import trimesh

import opnet
from opnet._checks import check_int, check_number, real_array
from opnet.inner_products import checked_gram


def _sliver(base, scale):
    """The base with one vertex moved towards the midpoint of the opposite edge of one of its faces, leaving
    that face with quality ≈ ``scale`` (and its neighbour about as thin)."""
    v = base.vertices.copy()
    i, j, m = base.faces[100]
    mid = 0.5 * (v[i] + v[j])
    v[m] = mid + scale * (v[m] - mid)
    return v


# -- near-degenerate geometry ---------------------------------------------------------------------------------


def test_near_degenerate_faces_warn_and_collapsed_ones_are_refused_with_their_index(base, base_basis):
    with pytest.warns(opnet.MeshWarning, match=r"below 0.0001 \(worst: face 100"):
        opnet.Mesh(_sliver(base, 1e-5), base.faces)
    with pytest.raises(opnet.MeshError, match=r"below 1e-08 \(worst: face 100"):
        opnet.Mesh(_sliver(base, 1e-10), base.faces)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a good mesh, and mild thinning, say nothing
        opnet.Mesh(base.vertices, base.faces)
        opnet.Mesh(_sliver(base, 0.1), base.faces)
    with pytest.warns(opnet.MeshWarning, match="shape 1"):  # the batched path names the shape
        opnet.shape_differences(base_basis, np.stack([base.vertices, _sliver(base, 1e-5)]))
    with pytest.raises(ValueError, match="shape 1"):
        opnet.shape_differences(base_basis, np.stack([base.vertices, _sliver(base, 1e-10)]))


def test_the_fast_path_checks_the_shapes_in_its_own_pass_as_check_shapes_does(base, base_basis):
    """shape_differences finds each shape's worst face quality in the operators' pass over the faces (√3 / Σ cot):
    the same qualities as opnet.face_quality, the same areas and weights, and the same errors and warnings as
    opnet.mesh.check_shapes, naming the first bad shape of any batch and counting them all, for any channel."""
    from opnet import spectral
    from opnet.mesh import check_shapes, face_quality

    rng = np.random.default_rng(0)
    shapes = np.stack([base.vertices + 0.003 * rng.standard_normal(base.vertices.shape) for _ in range(4)])
    shapes = np.concatenate([shapes, [_sliver(base, 1e-3), _sliver(base, 1e-6)]])
    with np.errstate(all="raise"):
        areas, weights, worst = spectral.areas_weights_and_worst_quality(shapes, base.faces)
    # to rounding, which grows like 1/quality (the q = 2e-6 sliver: 3e-10 relative); the thresholds are 1e-4 and 1e-8
    np.testing.assert_allclose(worst, face_quality(shapes, base.faces).min(-1), rtol=1e-8, atol=0)
    expected_areas, expected_weights = spectral.areas_and_cotan_weights(shapes, base.faces)
    assert np.array_equal(areas, expected_areas) and np.array_equal(weights, expected_weights)

    good = np.repeat(base.vertices[None], 7, axis=0)
    bad = good.copy()
    bad[[4, 6]] = _sliver(base, 1e-10)  # the third batch of two holds the first collapsed shape
    with pytest.raises(ValueError) as expected:
        check_shapes("vertices", bad, base.faces)
    assert "2 shapes have zero-area (collapsed) faces" in str(expected.value) and "first: shape 4" in str(
        expected.value
    )
    for channels in (opnet.KINDS, ["extrinsic"], [_Mine()]):
        with pytest.raises(ValueError) as got:
            opnet.shape_differences(base_basis, bad, channels, batch_size=2, progress=False)
        assert str(got.value) == str(expected.value), channels
    thin = good.copy()
    thin[5] = _sliver(base, 1e-5)
    with pytest.warns(opnet.MeshWarning, match=r"1 shapes have near-degenerate faces.*first: shape 5"):
        opnet.shape_differences(base_basis, thin, batch_size=2, progress=False)


def test_a_quality_that_only_the_fast_pass_rounds_below_the_limit_is_decided_by_the_full_check(
    base, base_basis, monkeypatch
):
    """Where the pass's √3 / Σ cot puts a shape below the refusal limit and check_shapes' formula does not (rounding
    at the limit), the full check decides: the operators are computed and nothing is raised or warned."""
    import opnet.inner_products as ip_module

    shapes = np.repeat(base.vertices[None], 3, axis=0)
    expected = opnet.shape_differences(base_basis, shapes, batch_size=2, progress=False)
    real = ip_module.areas_weights_and_worst_quality

    def rounded_down(vertices, faces, weights=True):
        areas, w, worst = real(vertices, faces, weights)
        return areas, w, np.zeros_like(worst)

    monkeypatch.setattr(ip_module, "areas_weights_and_worst_quality", rounded_down)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = opnet.shape_differences(base_basis, shapes, batch_size=2, progress=False)
    assert np.array_equal(got, expected)


def test_the_warning_threshold_is_where_one_face_outweighs_the_shape(base, base_basis):
    """The measurement behind the thresholds: thinning one face to quality q moves the conformal operator by
    ~0.015 / q (relative), so a mildly thin face is harmless and a face below 1e-4 dominates the whole shape."""
    exact = opnet.shape_difference(base_basis, base, "conformal")

    def change(scale):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", opnet.MeshWarning)
            D = opnet.shape_difference(base_basis, _sliver(base, scale), "conformal")
        return np.linalg.norm(D - exact) / np.linalg.norm(exact)

    assert change(0.1) == pytest.approx(0.08, rel=0.1)  # docs/usage.md's figures: q = 0.23, 2.4e-3, 2.4e-4
    assert change(1e-3) == pytest.approx(6, rel=0.1) and change(1e-4) == pytest.approx(60, rel=0.1)


@pytest.mark.parametrize("scale", [1e-30, 1e30])
def test_the_quality_tolerance_is_scale_free(base, scale):
    """A good mesh stays good and a sliver stays a sliver at any representable scale (they used to be reported
    as zero-area faces when far from unit size)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert opnet.Mesh(base.vertices * scale, base.faces).n_vertices == base.n_vertices
    with pytest.warns(opnet.MeshWarning, match="face 100"):
        opnet.Mesh(_sliver(base, 1e-5) * scale, base.faces)


def test_warnings_point_at_the_callers_line(base, base_basis):
    """However deep the check, the warning names the line of the user's code (this file)."""
    sliver = _sliver(base, 1e-5)
    for call in (
        lambda: opnet.Mesh(sliver, base.faces),
        lambda: base.with_vertices(sliver),
        lambda: opnet.shape_difference(base_basis, sliver),
        lambda: opnet.shape_differences(base_basis, sliver[None]),
    ):
        with pytest.warns(opnet.MeshWarning) as record:
            call()
        assert [w.filename for w in record] == [__file__]  # once, here


def test_a_checked_mesh_is_not_checked_again(base, base_basis):
    """encode on the base's triangulation takes the validated mesh straight to the fast path: one warning."""
    with pytest.warns(opnet.MeshWarning):
        mesh = opnet.Mesh(_sliver(base, 1e-5), base.faces)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        D = opnet.encode(mesh, base_basis)
    with pytest.warns(opnet.MeshWarning):  # the public batched path checks, and says so
        expected = opnet.shape_differences(base_basis, mesh.vertices[None])[0]
    np.testing.assert_allclose(D, expected)


def test_far_from_the_origin_is_named_as_the_cause(base):
    with pytest.raises(opnet.MeshError, match="smaller than its distance from the origin.*centre"):
        opnet.Mesh(base.vertices + 1e17, base.faces)


@pytest.mark.parametrize("scale", [1e-200, 1e200, 1e307])
def test_extreme_scales_are_named_and_normalize_area_accepts_them(base, scale):
    with pytest.raises(opnet.MeshError, match="spans .* rescale the coordinates.*normalize_area=True"):
        opnet.Mesh(base.vertices * scale, base.faces)
    unit = opnet.Mesh(base.vertices, base.faces, normalize_area=True)
    scaled = opnet.Mesh(base.vertices * scale, base.faces, normalize_area=True)
    np.testing.assert_allclose(scaled.vertices, unit.vertices, atol=1e-12)
    assert scaled.area == pytest.approx(1.0)


# -- shape mismatches get the right hint ----------------------------------------------------------------------


def test_a_path_where_a_mesh_is_expected_names_load_mesh(base_basis):
    with pytest.raises(TypeError, match=r"opnet.load_mesh\(path\)"):
        opnet.shape_difference(base_basis, "target.ply")


def test_a_target_with_another_vertex_count_is_named_as_such(base_basis):
    n = base_basis.mesh.n_vertices
    for rows in (n - 5, n + 3):
        target = np.resize(base_basis.mesh.vertices, (rows, 3))
        with pytest.raises(opnet.MeshError, match=f"coordinates are for {rows} vertices, this mesh has {n}"):
            opnet.shape_difference(base_basis, target)


def test_a_triangle_soup_gets_advice_that_works(base):
    soup_v = base.vertices[base.faces].reshape(-1, 3)
    soup_f = np.arange(len(soup_v)).reshape(-1, 3)
    for keep in (False, True):
        with pytest.raises(opnet.MeshError, match="triangle soup.*trimesh.Trimesh") as exc:
            opnet.Mesh(soup_v, soup_f, keep_largest_component=keep)
        assert "keep_largest_component=True" not in str(exc.value)  # the old advice, which then failed
    merged = trimesh.Trimesh(soup_v, soup_f)  # the advice, followed
    assert opnet.Mesh(merged.vertices, merged.faces).n_vertices == base.n_vertices


# -- types ----------------------------------------------------------------------------------------------------


def _numpy_entry_points(base, basis):
    """(name of the argument, a call taking the argument) for the numpy entry points."""
    V, k = base.vertices, basis.k
    D = np.eye(k)
    return [
        ("vertices", lambda x: opnet.shape_differences(basis, x), V[None]),
        ("X", lambda x: opnet.gram_matrix(basis, x), V),
        ("G", lambda x: opnet.recover_embedding(x, basis), D),
        ("D", lambda x: opnet.distortion_function(x, basis), D),
        ("D0", lambda x: opnet.interpolate(x, D, 0.5), D),
        ("DA", lambda x: opnet.analogy(x, D, D), D),
        ("X_gt", lambda x: opnet.d_R(x, V), V),
        ("X_gt", lambda x: opnet.d_E(x, V, base.faces), V),
        ("K", lambda x: opnet.pinv_psd(x), D),
        ("f", lambda x: basis.project(x), V),
        ("vertices", lambda x: opnet.vertex_areas(x, base.faces), V),
        ("matrix", lambda x: opnet.FunctionalMap(x, basis, basis).matrix, D),
    ] + (
        [  # the optimisation is the net extra's (torch)
            (
                "operators",
                lambda x: opnet.reconstruct(x, basis, channels=("area",), steps=1, progress=False),
                D[None, None],
            )
        ]
        if importlib.util.find_spec("torch")
        else []
    )


def test_complex_input_is_refused_not_truncated(base, base_basis):
    for name, call, good in _numpy_entry_points(base, base_basis):
        with pytest.raises(TypeError, match=f"{name} holds complex numbers"):
            call(good + 0j)  # the imaginary part is zero: still refused, never silently dropped


def test_strings_are_refused_and_lists_and_tensors_converted(base, base_basis):
    torch = importlib.util.find_spec("torch") and importlib.import_module("torch")  # tensors: the net extra
    for name, call, good in _numpy_entry_points(base, base_basis):
        with pytest.raises(TypeError, match=f"{name} must be a real array"):
            call("shape.ply")
        expected = call(good)
        for converted in (good.tolist(), *([torch.tensor(good)] if torch else [])):
            got = call(converted)
            np.testing.assert_allclose(
                got[0] if isinstance(got, tuple) else got, expected[0] if isinstance(expected, tuple) else expected
            )


def test_the_network_converts_what_it_can_without_loss_and_names_the_rest():
    torch = pytest.importorskip("torch")  # the network and the loss: the net extra
    net = opnet.OperatorNet(20, k=6, hidden=8).eval()
    ops = np.random.default_rng(0).normal(size=(2, 3, 6, 6)).astype(np.float32)
    expected = net(torch.from_numpy(ops))
    for same in (ops, ops.tolist()):
        torch.testing.assert_close(net(same), expected)
    half = torch.from_numpy(ops).half()  # widened without loss
    torch.testing.assert_close(net(half), net(half.float()))
    for lossy in (torch.from_numpy(ops).double(), ops.astype(np.float64)):
        with pytest.raises(
            TypeError,
            match=r"operators is float64 of shape \(2, 3, 6, 6\) but this network computes in float32.*x.float\(\)",
        ):
            net(lossy)
    with pytest.raises(TypeError, match="operators must hold real numbers"):
        net(torch.from_numpy(ops) * (1 + 0j))
    with pytest.raises(TypeError, match=r"operators must be a tensor \(B, 3, 6, 6\)"):
        net("operators.npy")
    with pytest.raises(ValueError, match=r"operators must have shape \(B, 3, 6, 6\)"):
        net(ops[:, :2])
    np.testing.assert_allclose(
        opnet.evaluate.predict(net, ops.astype(np.float64)), expected.double().detach().numpy(), rtol=1e-6
    )  # predict is the converting entry point
    pointnet = opnet.model.PointNetAutoencoder(20, n_points=10, latent=8, hidden=8)
    with pytest.raises(TypeError, match="vertices is float64"):
        pointnet(torch.zeros(1, 20, 3, dtype=torch.float64))


def test_the_loss_takes_numpy_targets_and_names_bad_arguments():
    torch = pytest.importorskip("torch")  # the network and the loss: the net extra
    pred = torch.randn(2, 10, 3, requires_grad=True)
    target = np.random.default_rng(0).normal(size=(2, 10, 3))
    loss = opnet.rigid_alignment_loss(pred, target)
    assert loss.dtype == pred.dtype  # the target is read in pred's precision
    torch.testing.assert_close(loss, opnet.rigid_alignment_loss(pred, torch.from_numpy(target).float()))
    with pytest.raises(TypeError, match="pred must be a floating-point tensor"):
        opnet.rigid_alignment_loss(pred.detach().numpy(), target)
    with pytest.raises(TypeError, match="target holds complex numbers"):
        opnet.rigid_alignment_loss(pred, target + 0j)


# -- user-defined inner products ------------------------------------------------------------------------------


class _Mine(opnet.InnerProduct):
    """A channel of one's own (the area inner product written out): no shared pass over the faces."""

    name = "mine"

    def project(self, vertices, faces, evecs):
        return evecs.T @ (opnet.vertex_areas(vertices, faces)[..., None] * evecs)


class _WrongShape(opnet.InnerProduct):
    name = "wrong shape"

    def project(self, vertices, faces, evecs):
        return np.eye(3)


class _NotSymmetric(opnet.InnerProduct):
    def project(self, vertices, faces, evecs):
        return np.triu(np.ones((evecs.shape[1],) * 2))


class _NotFinite(opnet.InnerProduct):
    def project(self, vertices, faces, evecs):
        return np.full((evecs.shape[1],) * 2, np.nan)


class _Negative(opnet.InnerProduct):
    def project(self, vertices, faces, evecs):
        return -evecs.T @ evecs


@pytest.mark.parametrize(
    "ip, message",
    [
        (
            _WrongShape(),
            r"_WrongShape.project \(inner product 'wrong shape'\) returned float64 ndarray of shape \(3, 3\)",
        ),
        (_NotSymmetric(), "_NotSymmetric.project .* non-symmetric"),
        (_NotFinite(), "_NotFinite.project .* NaN or infinite"),
        (_Negative(), "_Negative.project .* on the base: .* not positive semi-definite"),
    ],
)
def test_a_faulty_inner_product_is_named(base_basis, targets, ip, message):
    with pytest.raises(ValueError, match=message):
        opnet.shape_difference(base_basis, targets[0], ip)
    with pytest.raises(ValueError, match=message):
        opnet.shape_differences(base_basis, targets[0].vertices[None], [ip])


def test_the_built_in_inner_products_pass_the_checks(base_basis, targets):
    V = np.stack([t.vertices for t in targets])
    for ip in opnet.INNER_PRODUCTS.values():
        assert checked_gram(ip, "project_batch", V, base_basis.mesh.faces, base_basis.evecs).shape == (3, 30, 30)


# -- non-finite values and empty batches ----------------------------------------------------------------------


def test_non_finite_values_are_named_by_argument(base, base_basis):
    for name, call, good in _numpy_entry_points(base, base_basis):
        bad = good.copy()
        bad.flat[1] = np.nan
        with pytest.raises(ValueError, match=f"{name} contains 1 NaN or infinite values"):
            call(bad)
    torch = pytest.importorskip("torch")  # the network and the loss: the net extra
    net = opnet.OperatorNet(base.n_vertices, k=base_basis.k, hidden=8)
    with pytest.raises(ValueError, match="operators contains"):
        opnet.evaluate.predict(net, np.full((1, 3, base_basis.k, base_basis.k), np.inf))
    pred = torch.zeros(1, 4, 3)
    with pytest.raises(ValueError, match="target contains NaN"):
        opnet.rigid_alignment_loss(pred, torch.full((1, 4, 3), float("nan")))
    with pytest.raises(ValueError, match="t is nan"):
        opnet.interpolate(np.eye(3), np.eye(3), float("nan"))


def test_values_beyond_float32_and_bfloat16_tensors(base_basis):
    torch = pytest.importorskip("torch")  # the network and the loss: the net extra
    net = opnet.OperatorNet(20, k=4, hidden=8)
    with pytest.raises(ValueError, match="beyond the range of float32"):
        opnet.evaluate.predict(net, np.full((1, 3, 4, 4), 1e300))
    G = torch.eye(base_basis.k, dtype=torch.bfloat16)  # numpy has no bfloat16: widened first
    assert opnet.recover_embedding(G, base_basis).shape == (base_basis.mesh.n_vertices, 3)


def test_empty_batches_are_refused():
    torch = pytest.importorskip("torch")  # the network and the loss: the net extra
    with pytest.raises(ValueError, match="batch is empty"):
        opnet.rigid_alignment_loss(torch.zeros(0, 4, 3), torch.zeros(0, 4, 3))
    with pytest.raises(ValueError, match="n >= 1 points"):
        opnet.kabsch(np.zeros((0, 3)), np.zeros((0, 3)))  # the mean of no points is NaN
    with pytest.raises(ValueError, match="non-empty"):
        opnet.interpolate(np.eye(3), np.eye(3), [])
    with pytest.raises(ValueError, match="channels is empty"):
        opnet.shape_differences(opnet.eigenbasis(opnet.data.toy.capsule("quick"), 5), np.zeros((0, 434, 3)), [])
    with pytest.raises(ValueError, match="empty batch"):
        opnet.torch_ops.ShapeDifferences(opnet.eigenbasis(opnet.data.toy.capsule("quick"), 5))(torch.zeros(0, 434, 3))


# -- the shared argument checks ---------------------------------------------------------------------------------


def test_the_shared_checks():
    assert check_int("n", np.int64(3)) == 3 and check_int("n", None, none_ok=True) is None
    for bad in (0, -1, 2.5, True, "3", None):
        with pytest.raises(ValueError, match="n must be a positive integer"):
            check_int("n", bad)
    with pytest.raises(ValueError, match="steps must be an integer >= 2"):
        check_int("steps", 1, minimum=2)
    assert check_number("lr", 1e-3) == 1e-3
    for bad in (0, -1.0, float("inf"), float("nan"), "1e-3", True):
        with pytest.raises(ValueError, match="lr must be a positive number"):
            check_number("lr", bad)
    arr = np.zeros((2, 3), dtype=np.float32)
    assert real_array("x", arr, dtype=np.float32) is arr  # no copy when nothing changes
    assert real_array("x", np.zeros((4, 5, 3)), (..., 3)).shape == (4, 5, 3)
    with pytest.raises(ValueError, match=r"x must have shape \(B, 7, 3\), got \(2, 3\)"):
        real_array("x", arr, ("B", 7, 3))
    with pytest.raises(ValueError, match="could not be read as an array"):
        real_array("x", [[1, 2], [3]])
    with pytest.raises(TypeError, match="must be a real array"):
        real_array("x", np.array([True, False]))


def test_a_trainings_seed_and_folder_name_bad_input(tmp_path, tiny_collection):
    """The seed of `opnet train` (issue 40) is a non-negative integer that fits the generators; a run folder that
    is a file is named (issue 43)."""
    pytest.importorskip("torch")  # TrainConfig is the net extra's
    for bad in (-1, 2.5, True, 2**64):
        with pytest.raises(ValueError, match="seed must be an integer from 0"):
            opnet.train.TrainConfig(seed=bad)
    assert opnet.train.TrainConfig(seed=np.int64(2)).seed == 2
    a_file = tmp_path / "results"
    a_file.write_text("")
    with pytest.raises(ValueError, match="results is a file; give a directory path"):
        opnet.train.fit(tiny_collection(), epochs=1, hidden=8, run_dir=a_file, progress=False)


def test_the_findings_options_name_bad_input(tmp_path):
    """Seeds, comparisons, the reproduction's counts and folders (issues 40 and 43) answer bad input with errors
    that name the argument and the fix."""
    from opnet import reproduce
    from opnet.experiments import RunSpec, claims, compare

    for bad in (-1, 0, 2.5, "3", (0, 0), (0, -1), (True,)):
        with pytest.raises((ValueError, TypeError), match="seeds"):
            RunSpec(seeds=bad)
    with pytest.raises(TypeError, match=r"tuple\(range\(3\)\)"):
        RunSpec(seeds=3)  # a count where the seeds are listed: the fix spelled out
    for field in ("seeds", "jobs"):
        for bad in (0, -2, "x", 1.5):
            with pytest.raises(ValueError, match=f"{field} must be a count"):
                reproduce.ReproduceConfig(**{field: bad})
    for bad in (0, [], -1):
        with pytest.raises(ValueError, match="seeds must be a count"):
            opnet.experiments.ablation(None, ["A"], seeds=bad)
    shapes = dict(shapes=[0, 1], d_R_shapes=[[1.0, 2.0]], seeds=[0])
    rows = [dict(method="a", split="test", d_R=1.5, **shapes), dict(method="b", split="test", d_R=1.5, **shapes)]
    assert compare(rows, "a", {"method": "b"}).verdict == "no difference shown"  # a name is the method field
    for bad in ("rows", None, [1], {"method": "a"}):
        with pytest.raises(ValueError, match="rows must be a list of result rows"):
            compare(bad, "a", "b")
        with pytest.raises(ValueError, match="rows must be a list of result rows"):
            claims.judge("nn-far-behind", bad)
    assert claims.judge_all([]) == []  # no rows yet: no claim judged
    with pytest.raises(ValueError, match="unknown claim 'nn-behind'; the claims are"):
        claims.judge("nn-behind", rows)
    with pytest.raises(ValueError, match="claim must be a Claim"):
        claims.judge(3, rows)
    good = dict(key="k", statement="s", better={"method": "a"}, worse={"method": "b"}, source="mine")
    assert claims.judge(claims.Claim(**good), rows).missing  # rows of another table: none of the claim's
    for field, bad in (("key", ""), ("better", "a"), ("where", None), ("metric", ""), ("factor", 0), ("factor", True)):
        with pytest.raises(ValueError, match=f"{field} must be"):
            claims.Claim(**dict(good, **{field: bad}))
    assert compare(iter(rows), "a", "b").verdict == "no difference shown"  # any iterable of rows
    with pytest.raises(ValueError, match="b must be the fields of one method's rows"):
        compare(rows, "a", 3)
    with pytest.raises(ValueError, match="0 rows on 'tst'"):
        compare(rows, "a", "b", split="tst")
    for bad in ("d_Q", "n"):  # n_shapes is a count, not a metric
        with pytest.raises(ValueError, match=f"metric '{bad}' is not one of the row's per-shape metrics \\(d_R\\)"):
            compare([dict(r, n_shapes=2) for r in rows], "a", "b", metric=bad)
    assert type(RunSpec(seeds=[np.int64(1)]).seeds[0]) is int
    with pytest.raises(ValueError, match="factor must be a number > 0"):
        compare(rows, "a", "b", factor=0)
    a_file = tmp_path / "results"
    a_file.write_text("")
    with pytest.raises(ValueError, match="results is a file; give a folder"):
        reproduce.reproduce("quick", a_file)
