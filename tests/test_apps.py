"""Applications: the PointNet autoencoder, interpolation / analogy as shapes, and the ground-truth benchmarks."""

import pytest

pytest.importorskip("torch")  # the net extra: skipped by a core-only install

import numpy as np
import torch

import opnet
from opnet import apps, train
from opnet.data import generators
from opnet.experiments import report
from opnet.model import PointNetAutoencoder, build_model

FAST = dict(hidden=64, batch_size=8, lr=1e-3, progress=False)


@pytest.fixture(scope="module")
def coll(tiny_collection):
    return tiny_collection()


def _vertex_algebra(collection):
    """The coordinates themselves as a linear "latent" space: interpolation and analogy are exact affine maps."""
    n = collection.vertices.shape[1]
    return apps.ShapeAlgebra(
        "vertices", collection, lambda V: V.reshape(len(V), -1), lambda Z: Z.reshape(-1, n, 3), "latent"
    )


def _recording_algebra(collection, scheme="multiplicative"):
    """Operators combined by the algebra; ``decode`` records what it gets and returns the base shape."""
    seen = []
    base = collection.base_basis.mesh.vertices

    def decode(R):
        seen.append(R)
        return np.broadcast_to(base, (len(R), *base.shape)).copy()

    return apps.ShapeAlgebra("record", collection, apps._operators(collection), decode, "operators", scheme), seen


# -- PointNet autoencoder ---------------------------------------------------------------------------------


def test_pointnet_reads_its_points_in_any_order_and_decodes_with_operatornets_decoder(coll):
    net = PointNetAutoencoder(coll.vertices.shape[1], n_points=64, latent=32, hidden=16).choose_points(
        coll.base_basis.mesh.vertices
    )
    index = net.point_index.numpy()
    assert len(np.unique(index)) == 64
    # farthest-first points cover the shape: every vertex is closer to one of them than random picks manage
    V = coll.base_basis.mesh.vertices
    cover = lambda idx: np.linalg.norm(V[:, None] - V[idx][None], axis=-1).min(1).max()  # noqa: E731
    assert cover(index) < cover(np.random.default_rng(0).choice(len(V), 64, replace=False))
    X = torch.tensor(coll.vertices[:3])
    z = net.encode(X)
    assert z.shape == (3, 32) and net(X).shape == X.shape
    perm = torch.randperm(64)
    assert torch.allclose(net.point_mlp(X[:, net.point_index[perm]]).amax(1), z)  # max over points: order-free
    assert [type(m) for m in net.decoder] == [type(m) for m in opnet.OperatorNet(coll.vertices.shape[1], 20).decoder]
    again = build_model(net.config())
    assert isinstance(again, PointNetAutoencoder) and again.config() == net.config()
    with pytest.raises(ValueError, match=r"\(B, 434, 3\)"):
        net(X[:, :100])
    with pytest.raises(ValueError, match="n_points"):
        PointNetAutoencoder(434, n_points=435)


def test_pointnet_trains_checkpoints_and_resumes_like_operatornet(coll, tmp_path):
    net, hist = train.fit(coll, architecture="pointnet", n_points=64, epochs=3, run_dir=tmp_path / "pn", **FAST)
    assert isinstance(net, PointNetAutoencoder) and hist[-1]["train_loss"] < hist[0]["train_loss"]
    loaded = train.load_model(tmp_path / "pn", coll)
    assert isinstance(loaded, PointNetAutoencoder)
    assert torch.equal(loaded.point_index, net.point_index)  # the points read are saved with the weights
    X = torch.tensor(coll.vertices[:4])
    assert torch.allclose(loaded(X), net(X))
    _, more = train.fit(coll, architecture="pointnet", n_points=64, epochs=4, run_dir=tmp_path / "pn", **FAST)
    assert [h["epoch"] for h in more] == [1, 2, 3, 4] and more[:3] == hist  # resumed, not retrained
    with pytest.raises(train.CheckpointError, match="other model settings"):
        train.fit(coll, architecture="pointnet", n_points=32, epochs=4, run_dir=tmp_path / "pn", **FAST)
    with pytest.raises(train.CheckpointError, match="reads no operators"):
        train.load_model(tmp_path / "pn", channels="A+E")
    for wrong in (dict(channels="Ext"), dict(depth=2), dict(subtract_identity=False), dict(variant="ours")):
        with pytest.raises(ValueError, match="OperatorNet's options"):
            train.fit(coll, architecture="pointnet", **wrong, **FAST)
    with pytest.raises(ValueError, match="n_points is the PointNet"):
        train.fit(coll, n_points=64, **FAST)
    with pytest.raises(ValueError, match="architecture must be one of"):
        train.fit(coll, architecture="pointnet3", **FAST)
    with pytest.raises(train.CheckpointError, match="holds a pointnet run, not a operatornet one"):
        train.fit(coll, epochs=4, run_dir=tmp_path / "pn", **FAST)  # an OperatorNet into PointNet's run directory
    train.fit(coll, epochs=1, run_dir=tmp_path / "op", **FAST)
    with pytest.raises(train.CheckpointError, match="holds a operatornet run, not a pointnet one"):
        train.fit(coll, architecture="pointnet", epochs=1, run_dir=tmp_path / "op", **FAST)
    rows = opnet.evaluate.evaluate(coll, [opnet.evaluate.pointnet_method(loaded, coll)], ("test",))
    assert rows[0]["method"] == "PointNet AE" and np.isfinite(rows[0]["d_R"])


@pytest.mark.slow
def test_cli_trains_and_evaluates_the_pointnet_autoencoder(coll, tmp_path, cli):
    from opnet.data import save_collection

    manifest = save_collection(coll, tmp_path / "data" / "tiny")
    run = tmp_path / "pn"
    out = cli(
        "train",
        "--collection",
        str(manifest),
        "--architecture",
        "pointnet",
        "--points",
        "32",
        "--epochs",
        "2",
        "--hidden",
        "32",
        "--batch-size",
        "8",
        "--run-dir",
        str(run),
    )
    assert out.returncode == 0, out.stderr
    assert isinstance(train.load_model(run), PointNetAutoencoder) and train.load_model(run).n_points == 32
    out = cli("evaluate", "--run-dir", str(run), "--collection", str(manifest), "--json", str(tmp_path / "e.json"))
    assert out.returncode == 0, out.stderr
    assert "PointNet AE" in out.stdout and "Nearest neighbour (Int+Ext)" in out.stdout
    bad = cli(
        "train",
        "--collection",
        str(manifest),
        "--architecture",
        "pointnet",
        "--channels",
        "Ext",
        "--run-dir",
        str(tmp_path / "x"),
    )
    assert bad.returncode == 1 and "OperatorNet's options" in bad.stderr


# -- the algebra as shapes ------------------------------------------------------------------------------


def _same_up_to_rigid_motion(X, Y):
    assert np.all(opnet.d_R(Y, X) < 1e-20)


def test_latent_interpolation_and_analogy_are_the_affine_combinations_aligned_on_the_base(coll):
    alg = _vertex_algebra(coll)
    V = coll.vertices.astype(np.float64)
    t = np.array([0.0, 0.25, 1.0])
    path = alg.interpolate(3, 7, t)
    _same_up_to_rigid_motion(path, (1 - t)[:, None, None] * V[3] + t[:, None, None] * V[7])
    base = coll.base_basis.mesh.vertices
    np.testing.assert_allclose(path, opnet.rigid_align(path, np.broadcast_to(base, path.shape)), atol=1e-12)
    _same_up_to_rigid_motion(alg.analogy(1, 2, 3), V[3] + V[2] - V[1])
    batch = alg.analogy([1, 4], [2, 5], V[[3, 6]])  # indices and vertices mix
    _same_up_to_rigid_motion(batch, V[[3, 6]] + V[[2, 5]] - V[[1, 4]])


@pytest.mark.parametrize("scheme", apps.SCHEMES)
def test_operator_algebra_hands_the_decoder_the_combined_operators(coll, scheme):
    alg, seen = _recording_algebra(coll, scheme)
    D = opnet.shape_differences(coll.base_basis, coll.vertices[[1, 2, 3]].astype(np.float64), progress=False)
    alg.interpolate(1, 2, [0.0, 1.0])
    np.testing.assert_allclose(seen[-1], D[:2], atol=1e-9)  # the ends are the ends' operators
    alg.analogy(1, 1, 3)  # A : A :: C : C
    np.testing.assert_allclose(seen[-1][0], D[2], atol=1e-8)
    alg.analogy(1, 2, 1)  # A : B :: A : B
    np.testing.assert_allclose(seen[-1][0], D[1], atol=1e-8)
    alg.analogy(1, 2, 3)
    expected = [
        opnet.analogy(*D[:, c]) if scheme == "multiplicative" else D[2, c] + D[1, c] - D[0, c] for c in range(3)
    ]
    np.testing.assert_allclose(seen[-1][0], expected, atol=1e-10)


def test_nearest_neighbour_answers_with_a_training_shape(coll):
    alg = apps.nearest_neighbour_algebra(coll)
    j = coll.indices("train")[5]
    _same_up_to_rigid_motion(alg.analogy(2, 2, j), coll.vertices[j])  # D_X = D_j: j itself
    path = alg.interpolate(2, 30, np.linspace(0, 1, 5))
    train_shapes = coll.vertices[coll.indices("train")].astype(np.float64)
    assert all(min(opnet.d_R(s, p) for s in train_shapes) < 1e-12 for p in path)


def test_operatornet_and_pointnet_algebras_decode_shapes(coll):
    net, _ = train.fit(coll, epochs=2, **FAST)
    pn, _ = train.fit(coll, architecture="pointnet", n_points=32, epochs=2, **FAST)
    n = coll.vertices.shape[1]
    for alg in (
        apps.operatornet_algebra(net, coll),
        apps.operatornet_algebra(net, coll, scheme="linear"),
        apps.pointnet_algebra(pn, coll),
    ):
        path = alg.interpolate(0, 1, np.linspace(0, 1, 4))
        assert path.shape == (4, n, 3) and np.isfinite(path).all()
        np.testing.assert_allclose(path[0], alg.reconstruct(0)[0], atol=1e-5)  # t = 0 is the start shape's decoding
        assert alg.analogy(0, 1, 2).shape == (n, 3) and alg.analogy([0, 1], [1, 2], [2, 3]).shape == (2, n, 3)
    refined = apps.operatornet_algebra(net, coll, refine=dict(steps=3, channels="A+E"))
    assert refined.name == "OperatorNet (mult.) + refinement" and refined.unrefined is not None
    plain = refined.unrefined.analogy(0, 1, 2)
    out = refined.analogy(0, 1, 2)
    assert out.shape == (n, 3) and not np.allclose(out, plain)
    with pytest.raises(ValueError, match="other than init and progress"):
        apps.operatornet_algebra(net, coll, refine=dict(init="base"))
    with pytest.raises(TypeError, match="pointnet_algebra"):
        apps.operatornet_algebra(pn, coll)
    with pytest.raises(TypeError, match="operatornet_algebra"):
        apps.pointnet_algebra(net, coll)
    with pytest.raises(ValueError, match="max_shapes"):
        apps.operatornet_algebra(net, coll, max_shapes=0)


def test_shapes_are_checked(coll):
    alg = _vertex_algebra(coll)
    with pytest.raises(ValueError, match="n = 434"):
        alg.analogy(np.zeros((10, 3)), 1, 2)
    with pytest.raises(IndexError, match="has 40 shapes"):
        alg.analogy(0, 1, 99)
    with pytest.raises(ValueError, match="as many shapes"):
        alg.analogy([0, 1], [1, 2], 3)
    with pytest.raises(ValueError, match="NaN"):
        alg.analogy(np.full((434, 3), np.nan), 1, 2)
    with pytest.raises(ValueError, match="t must be"):
        alg.interpolate(0, 1, [])
    with pytest.raises(TypeError, match="indices into the collection"):
        alg.shapes("shape 1")
    with pytest.raises(ValueError, match="not made by a generator"):
        apps.analogy_quadruples(coll)


# -- metrics ----------------------------------------------------------------------------------------------


def test_path_metrics_score_the_truth_as_perfect_and_a_jump_as_a_jump(coll):
    V = coll.vertices.astype(np.float64)
    t = np.linspace(0, 1, 11)
    truth = (1 - t)[:, None, None] * V[0] + t[:, None, None] * V[1]
    m = apps.path_metrics(truth, truth, coll.faces)
    assert m["endpoint_d_R"] < 1e-20 and m["d_R_truth"] < 1e-20
    assert m["smoothness"] == pytest.approx(0.1, rel=0.05)  # ten equal steps (up to what alignment absorbs)
    jump = np.concatenate([np.repeat(V[:1], 10, 0), V[1:2]])
    assert apps.path_metrics(jump, truth, coll.faces)["smoothness"] == pytest.approx(1.0)
    stretched = truth * np.array([1.0, 1.0, 1.3])
    assert apps.path_metrics(stretched, truth, coll.faces)["distortion"] > 0.05
    # distortion is taken against the nearer true end: a path that stays at the start for its first half and at the
    # end for its second has the ends' edge lengths everywhere (0), the blend between two bodies does not
    halves = np.concatenate([np.repeat(V[:1], 6, 0), np.repeat(V[1:2], 5, 0)])
    assert apps.path_metrics(halves, truth, coll.faces)["distortion"] < 1e-12 < m["distortion"]
    assert apps.path_metrics(halves[::-1], truth, coll.faces)["distortion"] > 0.5 * m["distortion"]
    # right ends, wrong middle: only the in-between error sees it
    detour = truth.copy()
    detour[1:-1] *= [1.0, 1.0, 1.2]
    d = apps.path_metrics(detour, truth, coll.faces)
    assert d["endpoint_d_R"] < 1e-20 and d["d_R_truth"] > 1e-4
    still = apps.path_metrics(np.repeat(V[:1], 11, 0), truth, coll.faces)  # a path that never moves
    assert np.isnan(still["smoothness"])


# -- ground truth from the generator (the quick humans) ---------------------------------------------------


def test_generator_makes_the_collections_shapes_again_from_their_parameters(humans):
    idx = [0, 100, len(humans) - 1]
    V = generators.generate_shapes(humans, humans.params["phenotypes"][idx], humans.params["controls"][idx])
    np.testing.assert_allclose(V, humans.vertices[idx], atol=1e-4)  # float32 storage of the controls
    with pytest.raises(ValueError, match="controls"):
        generators.generate_shapes(humans, humans.params["phenotypes"][idx], humans.params["controls"][idx, :3])


def test_interpolated_controls_turn_each_joint_along_the_shortest_arc(humans):
    c0, c1 = humans.params["controls"][0].astype(np.float64), humans.params["controls"][200].astype(np.float64)
    out = generators.interpolate_controls(humans, c0, c1, [0.0, 0.5, 1.0])
    np.testing.assert_allclose(out[0], c0, atol=1e-5)
    np.testing.assert_allclose(out[2], c1, atol=1e-5)
    R = out[1, :, :3, :3]
    np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape), atol=1e-9)
    from scipy.spatial.transform import Rotation

    def angle(a, b):
        return Rotation.from_matrix(a[:, :3, :3].transpose(0, 2, 1) @ b[:, :3, :3]).magnitude()

    np.testing.assert_allclose(angle(out[0], out[1]), angle(out[1], out[2]), atol=1e-4)  # half-way


def test_quadruples_put_subjects_and_poses_in_their_roles(humans):
    from opnet.metrics import d_E

    pose = apps.analogy_quadruples(humans, "pose", 6)
    body = apps.analogy_quadruples(humans, "body", 6)
    assert len(pose) == len(body) == 6 and pose.A.shape == (6, *humans.vertices.shape[1:])
    unseen = humans.params["phenotypes"][humans.indices("test_subjects")]
    controls = humans.params["controls"]
    for Q, roles in (
        (pose, dict(A=(0, 0), B=(0, 1), C=(1, 0), X=(1, 1))),
        (body, dict(A=(0, 0), B=(1, 0), C=(0, 1), X=(1, 1))),
    ):  # (subject a|b, pose p|q)
        assert np.all(humans.split[Q.poses] == "test")  # poses of held-out sequences only ...
        assert all(np.any(np.all(np.isclose(unseen, s), axis=1)) for s in Q.phenotypes.reshape(-1, 6))  # unseen bodies
        assert np.all(Q.phenotypes[:, 0] != Q.phenotypes[:, 1]).any(axis=-1).all()
        for role, (s, p) in roles.items():
            again = generators.generate_shapes(humans, Q.phenotypes[:, s], controls[Q.poses[:, p]])
            np.testing.assert_allclose(getattr(Q, role), again, atol=1e-9, err_msg=role)
    # edge lengths follow the subject, not the pose: X shares its subject with C (pose) or with B (body)
    assert np.all(d_E(pose.C, pose.X, humans.faces) < d_E(pose.A, pose.X, humans.faces))
    assert np.all(d_E(body.B, body.X, humans.faces) < d_E(body.A, body.X, humans.faces))
    assert not np.allclose(pose.A, body.A)  # independent draws per kind
    np.testing.assert_array_equal(apps.analogy_quadruples(humans, "pose", 6).X, pose.X)  # seeded


def test_gender_quadruples_change_the_gender_alone(humans):
    """Gender transfer (Figs. 10 and 13): A and B are one subject in one pose, male and female; C is another subject,
    male, in another pose; X is C's subject female, in C's pose; the rest of each subject is an unseen one's."""
    from opnet.data.subjects import PHENOTYPES

    Q = apps.analogy_quadruples(humans, "gender", 4)
    controls = humans.params["controls"]
    g = PHENOTYPES.index("gender")
    unseen = humans.params["phenotypes"][humans.indices("test_subjects")]
    for role, (s, p, gender) in dict(A=(0, 0, 0.0), B=(0, 0, 1.0), C=(1, 1, 0.0), X=(1, 1, 1.0)).items():
        subject = Q.phenotypes[:, s].copy()  # as in A and C: male
        assert np.all(subject[:, g] == 0.0)
        other = [c for c in range(len(PHENOTYPES)) if c != g]  # the rest of the subject: an unseen one's
        assert all(np.any(np.all(np.isclose(unseen[:, other], v[other]), axis=1)) for v in subject)
        subject[:, g] = gender
        again = generators.generate_shapes(humans, subject, controls[Q.poses[:, p]])
        np.testing.assert_allclose(getattr(Q, role), again, atol=1e-9, err_msg=role)
    assert np.all(opnet.d_R(Q.A, Q.B) > 0)  # the gender moves the shape
    with pytest.raises(ValueError, match="kind must be one of"):
        apps.analogy_quadruples(humans, "age", 2)


def test_pose_paths_move_one_unseen_subject_between_test_poses(humans):
    from opnet.metrics import d_E

    P = apps.interpolation_paths(humans, "pose", 3, steps=4)
    assert P.truth.shape == (3, 4, *humans.vertices.shape[1:])
    # one body along each path (edge lengths barely change), which is none of the training bodies
    assert np.all(d_E(P.truth[:, 0], P.truth[:, -1], humans.faces) < 0.03)  # two bodies differ by ~0.05
    train = humans.vertices[humans.indices("train")].astype(np.float64)
    assert min(opnet.d_R(train, np.broadcast_to(P.truth[0, 0], train.shape))) > 1e-6
    assert not np.allclose(P.truth[:, 0], P.truth[:, -1])


def test_widgets_follow_their_controls(humans):
    from opnet import widgets

    alg = _vertex_algebra(humans)
    box = widgets.interpolation_explorer(humans, [alg], steps=3)
    first = box.image.value
    assert box.titles == ["start", "vertices, t = 0.5", "end"]  # the ends beside the methods
    start, end = (box.children[0].children[k].value for k in (0, 1))
    shapes = widgets.shape_labels(humans, np.concatenate([humans.indices("test"), humans.indices("test_subjects")]))
    V = {label: humans.vertices[i].astype(np.float64) for label, i in shapes.items()}
    sequence = {label: humans.subcollection[i] for label, i in shapes.items()}
    gap = {(a, b): np.sum((V[a] - V[b]) ** 2) for a in V for b in V if sequence[a] != sequence[b]}
    assert gap[start, end] == pytest.approx(max(gap.values()))  # the default: two sequences' most different shapes
    box.children[1].children[1].value = 1.0  # the slider
    assert box.titles == ["start", "vertices, t = 1.0", "end"] and box.image.value != first
    box.children[1].children[0].value = ()  # no method: the two ends
    assert box.titles == ["start", "end"]
    box = widgets.analogy_explorer(humans, [alg])
    assert box.titles[:4] == ["A", "B", "C", "true X"]  # a pose transfer: its answer is known
    a_pose, b_pose = box.controls[1].value, box.controls[3].value
    _, pose_idx, _ = apps.ground_truth_pool(humans)
    V = {label: humans.vertices[i].astype(np.float64) for label, i in widgets.shape_labels(humans, pose_idx).items()}
    gap = {(a, b): np.sum((V[a] - V[b]) ** 2) for a in V for b in V}
    assert gap[a_pose, b_pose] == pytest.approx(max(gap.values()))  # B in the pose most different from A's
    a_subject, b_subject, c_subject = box.controls[0], box.controls[2], box.controls[4]
    b_subject.value, c_subject.value = c_subject.value, a_subject.value  # A, C one subject; B another: still known
    assert "true X" in box.titles
    b_pose, c_pose = box.controls[3], box.controls[5]
    c_pose.value = b_pose.options[1]
    b_subject.value = a_subject.value
    b_pose.value = b_pose.options[2]  # A, B, C: one subject; three different poses: no known answer
    assert "true X" not in box.titles


@pytest.mark.filterwarnings("error::RuntimeWarning")  # an algebra whose every path is stuck: NaN, no numpy warning
def test_benchmarks_rows(humans):
    P = apps.interpolation_paths(humans, "body", 2, steps=5)
    assert P.truth.shape == (2, 5, *humans.vertices.shape[1:])
    alg = _vertex_algebra(humans)
    rows = apps.interpolation_benchmark(humans, [alg], P, progress=False)
    assert [r["method"] for r in rows] == ["Ground truth", "vertices"]
    algebras = [_recording_algebra(humans, scheme)[0] for scheme in apps.SCHEMES]  # one network, two algebras
    both = apps.interpolation_benchmark(humans, algebras, P, progress=False)[1:]
    assert len({report.row_identity(dict(r, table="interpolation")) for r in both}) == len(apps.SCHEMES)
    assert rows[1]["endpoint_d_R"] < 1e-20  # vertex lerp keeps the ends
    assert rows[1]["d_R_truth"] > 0  # ... but is not the generator's in-between body
    Q = apps.analogy_quadruples(humans, "pose", 3)
    row = apps.analogy_benchmark(humans, [alg], Q, progress=False)[0]
    assert row["n"] == 3 and row["d_R_direct"] < 1e-20 and row["d_R"] > 0
    assert {"d_R", "d_V", "d_E", "d_R_median", "kind", "scheme"} <= set(row)


def test_pointnet2_encodes_as_its_written_out_set_abstraction():
    """PointNet2Autoencoder.encode groups each point's first-layer term once (W_f f_j) and takes a max: the codes and
    every weight gradient equal the set abstraction written out, offsets and features concatenated per group member,
    the whole MLP, then amax."""
    from opnet.model import PointNet2Autoencoder, farthest_points

    n = 300
    base = np.random.default_rng(0).normal(size=(n, 3))
    torch.manual_seed(0)
    net = PointNet2Autoencoder(n, 200, latent=64, hidden=16).choose_points(base)
    x = torch.as_tensor(base, dtype=torch.float32) + 0.05 * torch.randn(4, n, 3, generator=torch.Generator())

    def written_out(vertices):
        xyz, features = vertices[:, net.point_index], None
        for (centres, group, _), radius, level in zip(net.LEVELS, net.radius, net.levels):
            centre = torch.stack([p[i] for p, i in zip(xyz, farthest_points(xyz, centres))])
            members = []
            for s in range(len(xyz)):  # each shape, each centre: its `group` nearest points within the radius
                d = torch.linalg.norm(xyz[s][None] - centre[s][:, None], dim=-1)
                near, idx = d.sort(dim=1)
                idx = torch.where(near[:, :group] <= radius, idx[:, :group], idx[:, :1])
                one = xyz[s][idx] - centre[s][:, None]
                members.append(one if features is None else torch.cat([one, features[s][idx]], dim=-1))
            xyz, features = centre, level(torch.stack(members)).amax(dim=2)
        return net.global_mlp(torch.cat([xyz, features], dim=-1)).amax(dim=1)

    def codes_and_gradients(encode):
        net.zero_grad()
        z = encode(x)
        (z * torch.linspace(-1, 1, z.shape[1])).sum().backward()
        return z.detach(), [p.grad.clone() for p in net.parameters() if p.grad is not None]

    z, grads = codes_and_gradients(net.encode)
    z_ref, grads_ref = codes_and_gradients(written_out)
    assert len(grads) == len(grads_ref) == 2 * (2 * 3 + 3)  # the two levels' and the global MLP's layers
    torch.testing.assert_close(z, z_ref, rtol=1e-5, atol=1e-6)
    for g, g_ref in zip(grads, grads_ref):
        torch.testing.assert_close(g, g_ref, rtol=1e-4, atol=1e-4 * float(g_ref.abs().max()))


def test_the_other_point_set_autoencoders_train_and_read_their_points(coll, tmp_path):
    """The paper's other PointNet (with its input transform, which starts as the identity) and the PointNet++
    autoencoder (Fig. 17) train like the PointNet AE, and are loaded back by their checkpoints' architecture."""
    from opnet.model import PointNet2Autoencoder, PointNetAutoencoder, PointNetTransformerAutoencoder, farthest_points

    torch.manual_seed(0)
    plain = PointNetAutoencoder(coll.vertices.shape[1], 64, hidden=16)
    torch.manual_seed(0)
    stn = PointNetTransformerAutoencoder(coll.vertices.shape[1], 64, hidden=16)
    x = torch.as_tensor(coll.vertices[:3], dtype=torch.float32)
    assert torch.equal(plain.encode(x), stn.encode(x))  # the same weights; the transform starts as the identity
    points = torch.rand(2, 50, 3, generator=torch.Generator().manual_seed(2))
    idx = farthest_points(points, 10)
    assert idx[:, 0].eq(0).all() and all(len(set(i.tolist())) == 10 for i in idx)  # distinct, from the first point
    chosen = points[0, idx[0]]  # each next point is the one farthest from those before it
    for i in range(1, 10):
        nearest = torch.cdist(points[0], chosen[:i]).amin(1)
        assert nearest[idx[0, i]] == nearest.max()
    for arch, cls in (("pointnet_stn", PointNetTransformerAutoencoder), ("pointnet2", PointNet2Autoencoder)):
        net, hist = train.fit(coll, architecture=arch, epochs=3, run_dir=tmp_path / arch, **FAST)
        assert type(net) is cls and hist[-1]["train_loss"] < hist[0]["train_loss"]
        loaded = train.load_model(tmp_path / arch)
        assert type(loaded) is cls and torch.equal(loaded.encode(x), net.encode(x))
    R = torch.linalg.qr(torch.randn(3, 3, generator=torch.Generator().manual_seed(1)))[0]
    stn = train.load_model(tmp_path / "pointnet_stn")
    assert not torch.allclose(stn.transform(x @ R), stn.transform(x))  # trained, it reads the points' orientation
