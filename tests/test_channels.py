"""Channels are data: a researcher's own inner product goes through collections (computed once, cached beside them,
keyed by its implementation), training, evaluation, the ablation, refinement and the command line. The inner
product here is the test's own: the area weighted by the squared distance to the area-weighted centroid, which is
rigid-invariant and has numpy, batched and torch forms."""

import pytest

pytest.importorskip("torch")  # the net extra: skipped by a core-only install

import importlib
import json
import os
import subprocess
import sys

import numpy as np
import torch

import opnet
from opnet import ChannelError, train
from opnet.data import channels as data_channels
from opnet.data import save_collection

RADIAL_SOURCE = '''
import numpy as np
import opnet


class RadialArea(opnet.InnerProduct):
    """M = diag(a_i |v_i - c|^2), c the area-weighted centroid: rigid-invariant, not intrinsic."""

    name = "radial area"

    def project(self, vertices, faces, evecs):
        a = opnet.vertex_areas(vertices, faces)
        c = (a[..., None] * vertices).sum(-2, keepdims=True) / a.sum(-1)[..., None, None]
        w = a * ((vertices - c) ** 2).sum(-1) * SCALE
        return np.einsum("pi,...p,pj->...ij", evecs, w, evecs)

    project_batch = project

    def project_torch(self, vertices, faces, evecs):
        import torch

        v = vertices[:, faces]  # (B, m, 3, 3)
        cross = torch.linalg.cross(v[:, :, 1] - v[:, :, 0], v[:, :, 2] - v[:, :, 0])
        double = torch.linalg.vector_norm(cross, dim=-1)
        third = (double / 6).repeat_interleave(3, 1)
        a = vertices.new_zeros(vertices.shape[:2]).index_add_(1, faces.reshape(-1), third)
        c = (a[..., None] * vertices).sum(1, keepdim=True) / a.sum(1)[:, None, None]
        w = a * ((vertices - c) ** 2).sum(-1) * SCALE
        return (evecs.T * w.unsqueeze(1)) @ evecs


SCALE = 1.0
'''


@pytest.fixture(scope="module")
def radial_module(tmp_path_factory):
    """The inner product as a module on the path (what ``--channels area,mymodule:RadialArea`` imports)."""
    folder = tmp_path_factory.mktemp("mypackage")
    (folder / "radial_channels.py").write_text(RADIAL_SOURCE)
    sys.path.insert(0, str(folder))
    module = importlib.import_module("radial_channels")
    yield module
    sys.path.remove(str(folder))
    sys.modules.pop("radial_channels", None)


@pytest.fixture(scope="module")
def Radial(radial_module):
    return radial_module.RadialArea


@pytest.fixture(scope="module")
def coll(tiny_collection):
    return tiny_collection()


@pytest.fixture
def stored(coll, tmp_path):
    """The tiny collection written and read back (so that channels added to it are cached beside it)."""
    return opnet.data.read_collection(save_collection(coll, tmp_path / "tiny"))


FAST = dict(hidden=32, batch_size=8, progress=False)


# ------------------------------------------------------------------------------------------------------------------
# identity


def test_a_channel_is_its_name_and_a_digest_of_its_code(Radial, radial_module, tmp_path):
    ip = Radial()
    assert opnet.channel_digest(ip) == opnet.channel_digest(Radial()) == opnet.channel_digest(Radial)
    assert len(opnet.channel_digest(ip)) == 16
    opnet.testing.check_inner_product(ip, opnet.data.toy.capsule("quick"))  # it is an inner product, torch form too
    # a docstring or a comment is not code; a changed line or parameter is
    folder = tmp_path / "edited"
    folder.mkdir()
    variants = {
        "same": RADIAL_SOURCE.replace("rigid-invariant, not intrinsic", "reworded").replace(
            "\n    name =", "\n    # x\n    name ="
        ),
        "edited": RADIAL_SOURCE.replace("* SCALE\n        return np.einsum", "* SCALE * 2\n        return np.einsum"),
    }
    digests = {}
    for key, text in variants.items():
        (folder / f"radial_{key}.py").write_text(text)
        sys.path.insert(0, str(folder))
        try:
            digests[key] = opnet.channel_digest(importlib.import_module(f"radial_{key}").RadialArea())
        finally:
            sys.path.remove(str(folder))
    assert digests["same"] == opnet.channel_digest(ip) != digests["edited"]
    # instance parameters are part of it, and classes without source (exec) are told apart by their compiled code
    ip2 = Radial()
    ip2.t = 0.1
    assert opnet.channel_digest(ip2) != opnet.channel_digest(ip)
    made = [{}, {}]
    for space, factor in zip(made, ("1", "2")):
        exec(
            f"import opnet\nclass E(opnet.AreaInnerProduct):\n    name = 'e'\n    version = None\n"
            f"    def project(self, v, f, e):\n        return {factor} * super().project(v, f, e)\n",
            space,
        )
    assert opnet.channel_digest(made[0]["E"]()) != opnet.channel_digest(made[1]["E"]())


def test_names_are_checked_resolved_registered_and_imported(Radial):
    class Area(opnet.InnerProduct):
        name = "area"

        def project(self, vertices, faces, evecs):
            return np.eye(evecs.shape[1])

    with pytest.raises(ChannelError, match="takes the built-in channel name 'area'.*name of its own"):
        opnet.get_inner_product(Area())
    for bad in ("a,b", "x:y", ""):
        named = type("Bad", (Radial,), {"name": bad})
        with pytest.raises(ChannelError, match="must be a non-empty string without ','"):
            opnet.get_inner_product(named())
    with pytest.raises(
        ChannelError, match=r"unknown channel 'radial area'.*known channels are.*register_inner_product"
    ):
        opnet.get_inner_product("radial area")
    assert type(opnet.get_inner_product("radial_channels:RadialArea")) is Radial
    with pytest.raises(
        ChannelError, match="module 'no_such_package.channels' does not import.*named 'no_such_package'"
    ):
        opnet.get_inner_product("no_such_package.channels:MyIP")
    with pytest.raises(ChannelError, match="has no 'Missing'"):
        opnet.get_inner_product("radial_channels:Missing")
    with pytest.raises(ChannelError, match="not an opnet.InnerProduct"):
        opnet.get_inner_product("radial_channels:SCALE")
    try:
        assert opnet.register_inner_product(Radial()).name == "radial area"
        assert type(opnet.get_inner_product("radial area")) is Radial
        other = type(
            "RadialArea", (Radial,), {"project_batch": lambda self, v, f, e: 2 * Radial.project(self, v, f, e)}
        )
        with pytest.raises(ChannelError, match="registered already by another implementation"):
            opnet.register_inner_product(other())
        opnet.register_inner_product(other(), replace=True)
    finally:
        from opnet.inner_products import _REGISTRY

        _REGISTRY.pop("radial area", None)


def test_the_channel_vocabulary_lives_in_the_channel_layer():
    """Parsing, names and labels are opnet.inner_products'; the data package and evaluate re-export them, and the
    device rule is opnet.devices' (opnet.train's as before)."""
    from opnet import devices, evaluate, inner_products

    assert data_channels.split_channels is inner_products.split_channels
    assert evaluate.channel_names is inner_products.channel_names
    assert evaluate.channel_label is inner_products.channel_label
    assert train.resolve_device is train.config.resolve_device is devices.resolve_device
    assert inner_products.split_channels("A+E") == ["area", "extrinsic"]
    assert inner_products.split_channels(" area, radial_channels:RadialArea") == ["area", "radial_channels:RadialArea"]
    one = opnet.AreaInnerProduct()
    assert inner_products.split_channels(one)[0] is one and inner_products.split_channels(opnet.AreaInnerProduct) == [
        opnet.AreaInnerProduct
    ]
    assert inner_products.channel_names("area,extrinsic") == ("area", "extrinsic")
    labels = {"A+E+C": "Int+Ext", "conformal,area": "Int", "extrinsic": "Ext", "area,extrinsic": "A+E", "Conf": "Conf"}
    for channels, label in labels.items():
        assert inner_products.channel_label(channels) == label
    assert inner_products.channel_label(["area", "my ip"]) == "Area+my ip"


# ------------------------------------------------------------------------------------------------------------------
# collections


def test_with_channels_computes_orders_and_caches_a_new_channel(stored, Radial, tmp_path):
    data_file = next(tmp_path.glob("tiny.*.npz"))
    before = (data_file.stat().st_mtime_ns, (tmp_path / "tiny.json").read_text())
    mine = stored.with_channels(["area", "extrinsic", Radial()])
    assert mine.channels == ("area", "extrinsic", "radial area") and mine.operators.shape[1] == 3
    np.testing.assert_array_equal(mine.operators[:, :2], stored.operators[:, [0, 2]])
    expected = opnet.shape_differences(stored.base_basis, stored.vertices[:3].astype(np.float64), [Radial()])
    np.testing.assert_allclose(mine.operators[:3, 2], expected[:, 0], rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(mine.operators_for(["radial area", "area"]), mine.operators[:, [2, 0]])
    assert mine.operators_for([Radial(), "area"]).shape == (len(stored), 2, 20, 20)
    assert mine.digests["radial area"] == opnet.channel_digest(Radial())
    # the collection itself is untouched; the channel has one file of its own, named by its digest
    assert (data_file.stat().st_mtime_ns, (tmp_path / "tiny.json").read_text()) == before
    cached = list(tmp_path.glob("tiny.channel.radial_area.*.npz"))
    assert len(cached) == 1 and opnet.channel_digest(Radial()) in cached[0].name
    # asked again (even of a fresh read), it is read back, not computed
    again = opnet.data.read_collection(tmp_path / "tiny")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(data_channels, "compute_operators", lambda *a, **k: pytest.fail("computed again"))
        back = again.with_channels(["area", Radial()])
    np.testing.assert_array_equal(back.operators[:, 1], mine.operators[:, 2])
    # a subset keeps its channels
    assert mine.subset([0, 3]).channels == mine.channels


def test_a_channel_without_project_batch_runs_in_processes(coll, Radial):
    class Slow(opnet.InnerProduct):  # only project: computed shape by shape
        name = "slow radial"

        def project(self, vertices, faces, evecs):
            return Radial().project(vertices, faces, evecs)

    serial = coll.with_channels([Slow()], n_jobs=1)
    parallel = coll.with_channels([Slow()], n_jobs=2)
    np.testing.assert_array_equal(serial.operators, parallel.operators)
    np.testing.assert_allclose(serial.operators[:, 0], coll.with_channels([Radial()]).operators[:, 0], rtol=1e-6)


def test_channel_errors_name_the_fix(stored, Radial, radial_module, tmp_path):
    mine = stored.with_channels([*stored.channels, Radial()])
    with pytest.raises(
        ChannelError, match=r"holds the channels \['area', 'conformal', 'extrinsic'\], not 'radial area'.*with_channels"
    ):
        stored.operators_for(["area", Radial()])
    with pytest.raises(ChannelError, match="unknown channel 'volume'.*with_channels"):
        stored.with_channels(["volume"])
    with pytest.raises(ValueError, match="with_channels"):
        train.fit(stored, channels=["area", Radial()], epochs=1, **FAST)
    with pytest.raises(ChannelError, match="twice"):
        stored.with_channels(["area", "area"])
    # another implementation under the same name: refused where the collection holds the old one
    edited = type("RadialArea", (Radial,), {"project_batch": lambda self, v, f, e: 3 * Radial.project(self, v, f, e)})
    with pytest.raises(
        ChannelError, match="channel 'radial area' was computed by another implementation.*recompute=True"
    ):
        mine.operators_for([edited()])
    with pytest.raises(ChannelError, match="another implementation"):
        mine.with_channels(["area", edited()])
    redone = mine.with_channels(["area", edited()], recompute=True)
    np.testing.assert_allclose(redone.operators[:, 1], 3 * mine.operators_for(["radial area"])[:, 0], rtol=1e-5)
    assert len(list(tmp_path.glob("tiny.channel.radial_area.*.npz"))) == 2  # one file per implementation
    # read back from disk, the channel's operators select by name, but new shapes need its class
    saved = opnet.data.read_collection(save_collection(mine, tmp_path / "mine"))
    assert saved.channels == mine.channels and saved.digests == mine.digests
    np.testing.assert_array_equal(saved.operators_for(["radial area"]), mine.operators_for(["radial area"]))
    with pytest.raises(ChannelError, match="holds the operators of channel 'radial area' but not its inner product"):
        saved.inner_products()
    assert [ip.name for ip in saved.inner_products(["area", Radial()])] == ["area", "radial area"]


def test_a_channel_that_sees_rigid_motions_warns(coll):
    class Height(opnet.InnerProduct):
        name = "height"

        def project(self, vertices, faces, evecs):
            a = opnet.vertex_areas(vertices, faces) * (2 + vertices[:, 2])
            return evecs.T @ (a[:, None] * evecs)

    with pytest.warns(UserWarning, match="'height' is not invariant to rigid motions"):
        assert coll.with_channels([Height()], n_jobs=1).channels == ("height",)


def test_folder_and_mapped_collections_take_channels(tmp_path, Radial, humans, root, tiny_collection):
    import trimesh

    c = tiny_collection(n=16)
    for i, v in enumerate(c.vertices):
        trimesh.Trimesh(v, c.faces, process=False).export(tmp_path / f"s{i:02d}.ply")
    folder = opnet.data.load_folder(tmp_path, k=12, channels=["extrinsic", Radial()], progress=False)
    assert folder.channels == ("extrinsic", "radial area") and folder.operators.shape[1:] == (2, 12, 12)
    few = humans.indices("test")[:2]
    true = opnet.data.mapped_collection(humans, "2k", "true", indices=few, root=root, n_jobs=1, progress=False)
    mine = opnet.data.mapped_collection(
        humans, "2k", "true", indices=few, root=root, n_jobs=1, channels=["area", Radial()], progress=False
    )
    assert true.channels == opnet.KINDS and mine.channels == ("area", "radial area")
    np.testing.assert_array_equal(mine.operators[:, 0], true.operators[:, 0])
    with pytest.raises(ChannelError, match="through the same maps: opnet.data.mapped_collection"):
        true.with_channels([Radial()])


# ------------------------------------------------------------------------------------------------------------------
# training, evaluation, the ablation, refinement


def test_fit_evaluate_and_load_with_a_channel_of_ones_own(stored, Radial, tmp_path):
    mine = stored.with_channels(["area", "extrinsic", Radial()])
    net, history = train.fit(mine, channels=["area", Radial()], epochs=2, run_dir=tmp_path / "run", **FAST)
    assert net.channels == ("area", "radial area") and len(history) == 2
    config = json.loads((tmp_path / "run" / "config.json").read_text())
    assert config["data"]["channels"] == [
        {"name": "area", "digest": opnet.channel_digest("area")},
        {"name": "radial area", "digest": opnet.channel_digest(Radial())},
    ]
    assert config["channel_specs"] == {"area": None, "radial area": "radial_channels:RadialArea"}  # not compared
    rows = opnet.evaluate.evaluate(mine, [opnet.evaluate.operatornet_method(net, mine)], ("val", "test"))
    assert [(r["method"], r["channels"], r["split"]) for r in rows] == [
        ("OperatorNet (Area+radial area)", ["area", "radial area"], s) for s in ("val", "test")
    ]
    nn = opnet.evaluate.nearest_neighbour_method(mine, net.channels)
    assert nn.channels == ("area", "radial area")
    # the fingerprint covers the run's channels only: the run loads on any collection holding them
    loaded = train.load_model(tmp_path / "run", stored.with_channels(["area", Radial()]), channels=["area", Radial()])
    np.testing.assert_array_equal(
        opnet.decode(loaded, mine.operators[:2], mine.channels), opnet.decode(net, mine.operators[:2], mine.channels)
    )
    # an edited class: loading, evaluating and resuming name the channel
    edited = type("RadialArea", (Radial,), {"project_batch": lambda self, v, f, e: 2 * Radial.project(self, v, f, e)})
    with pytest.raises(train.CheckpointError, match="channel 'radial area' as computed by another implementation"):
        train.load_model(tmp_path / "run", channels=["area", edited()])
    other = stored.with_channels(["area", edited()])
    with pytest.raises(
        train.CheckpointError, match=r"channels \['radial area'\] were computed by another implementation"
    ):
        train.load_model(tmp_path / "run", other)
    with pytest.raises(ChannelError, match="trained on channel 'radial area' computed by another implementation"):
        opnet.evaluate.operatornet_method(net, other)
    with pytest.raises(
        train.CheckpointError, match=r"channels \['radial area'\] were computed by another implementation"
    ):
        train.fit(other, channels=["area", edited()], epochs=3, run_dir=tmp_path / "run", **FAST)


def test_a_run_from_before_channels_were_data_loads_and_resumes(stored, tmp_path):
    """Runs written before the data config recorded channels (fingerprint of all three operators) still load, and a
    resumed one goes on in its own format to the same weights as an uninterrupted run."""
    run = tmp_path / "old"
    train.fit(stored, channels=["extrinsic"], epochs=1, run_dir=run, **FAST)
    for name in ("latest.pt", "best.pt"):  # rewrite the run as the old code wrote it
        ckpt = torch.load(run / name, weights_only=True)
        data = {k: v for k, v in ckpt["config"]["data"].items() if k not in ("fingerprint_version", "channels")}
        ckpt["config"]["data"] = dict(data, fingerprint=train.collection_fingerprint(stored))
        torch.save(ckpt, run / name)
    assert train.load_model(run, stored).channels == ("extrinsic",)
    resumed, history = train.fit(stored, channels=["extrinsic"], epochs=3, run_dir=run, **FAST)
    assert [h["epoch"] for h in history] == [1, 2, 3]
    straight, _ = train.fit(stored, channels=["extrinsic"], epochs=3, **FAST)
    for a, b in zip(resumed.state_dict().values(), straight.state_dict().values()):
        torch.testing.assert_close(a, b)
    assert "channels" not in torch.load(run / "latest.pt", weights_only=True)["config"]["data"]


def test_the_ablation_is_a_list_of_runs(stored, Radial, tmp_path):
    mine = stored.with_channels(["area", "extrinsic", Radial()])
    table = opnet.ablation(
        mine, channel_sets=[["area"], ["area", Radial()]], depths=[1, 2], epochs=1, run_root=tmp_path, **FAST
    )
    runs = [r for r in table if r["run"] is not None]
    assert [(r["channels"], r["depth"], r["split"]) for r in runs] == [
        (c, d, "val") for c in (["area"], ["area", "radial area"]) for d in (1, 2)
    ]
    assert [r["channels"] for r in table if r["run"] is None] == [["area"], ["area", "radial area"]]  # NN on each
    names = sorted(p.name for p in tmp_path.iterdir() if p.is_dir())
    assert names[0].startswith("ablation-Area-d1-") and names[1].startswith("ablation-Area-d2-")
    assert any(p.name.startswith("ablation-area+radial_area-") for p in tmp_path.iterdir())
    from opnet import reproduce

    quick = reproduce.BUDGETS["quick"]
    assert reproduce.run_path(tmp_path, stored, "table1", opnet.KINDS, budget=quick).name.startswith("table1-A+E+C-d1-")
    # the channel order is the network's input order: another order is another run
    assert reproduce.run_path(tmp_path, stored, "table1", ["extrinsic", "area"], budget=quick).name.startswith(
        "table1-extrinsic+area-d1-"
    )
    assert reproduce.run_path(tmp_path, mine, "ablation", ["area", Radial()], 2, budget=quick).name.startswith(
        "ablation-area+radial_area-"
    )
    text = table.markdown()
    assert "| Area+radial area |" in text and "depth 2" in text and "baseline" in text
    assert text.startswith("d_R ×10⁻⁴ on val") and table.markdown(scale=2).startswith("d_R ×0.5 on val")  # the unit
    again = opnet.ablation(
        mine, channel_sets=[["area"]], depths=[1], epochs=1, run_root=tmp_path, baselines=False, **FAST
    )
    assert again[0]["d_R"] == runs[0]["d_R"]  # the finished run was loaded, not trained again


def test_reconstruct_and_the_algebra_use_the_channel(stored, Radial):
    mine = stored.with_channels(["area", Radial()])
    ops = mine.operators_for(["area", Radial()])[:2]
    X = opnet.reconstruct(ops, mine.base_basis, channels=["area", Radial()], init="base", steps=5, progress=False)
    assert X.shape == (2, mine.vertices.shape[1], 3) and np.isfinite(X).all()
    module = opnet.torch_ops.ShapeDifferences(mine.base_basis, ["area", Radial()])
    at_x = module(torch.tensor(X)).numpy()
    at_base = module(torch.tensor(np.broadcast_to(mine.base_basis.mesh.vertices, X.shape).copy())).numpy()
    assert np.linalg.norm(at_x - ops) < np.linalg.norm(at_base - ops)  # the operators moved towards the target

    class NoTorch(opnet.InnerProduct):
        name = "no torch"

        def project(self, vertices, faces, evecs):
            return Radial().project(vertices, faces, evecs)

    with pytest.raises(ValueError, match=r"\['no torch'\] have no torch form: implement project_torch"):
        opnet.reconstruct(ops[:, :1], mine.base_basis, channels=[NoTorch()], steps=1, progress=False)
    net, _ = train.fit(mine, channels=[Radial()], epochs=1, **FAST)
    algebra = opnet.apps.operatornet_algebra(net, mine)
    assert algebra.interpolate(0, 1, [0.0, 0.5, 1.0]).shape == (3, mine.vertices.shape[1], 3)
    refined = opnet.apps.operatornet_algebra(net, mine, refine=dict(channels=[Radial()], steps=2))
    assert refined.analogy(0, 1, 2).shape == (mine.vertices.shape[1], 3)


def test_decode_of_encode_names_no_channels_for_a_network_of_other_channels(toy_collection, Radial):
    """A network trained on channels that are not the paper's three: ``encode`` against its collection gives that
    collection's channels, and ``decode`` reads the network's own by default, so neither call names them."""
    for channels in (("area",), ("extrinsic", Radial())):
        coll = toy_collection().with_channels(channels)
        torch.manual_seed(0)
        net, _ = train.fit(coll, epochs=2, **FAST)
        assert net.channels == coll.channels == opnet.inner_products.channel_names(channels)
        i = int(coll.indices("test")[0])
        D = opnet.encode(coll.mesh(i), coll)
        assert D.shape == (len(channels), coll.base_basis.k, coll.base_basis.k)
        np.testing.assert_allclose(D, coll.operators[i], rtol=1e-4, atol=1e-5 * np.abs(D).max())
        X = opnet.decode(net, D)
        assert X.shape == (coll.vertices.shape[1], 3)
        np.testing.assert_allclose(X, opnet.decode(net, D, channels=net.channels), rtol=1e-6)
        assert opnet.encode(coll.mesh(i), coll.base_basis).shape[0] == 3  # a bare basis: the paper's three
    with pytest.raises(ValueError, match="the network's channels, the default.*channels=opnet.KINDS"):
        opnet.decode(net, opnet.encode(coll.mesh(i), coll.base_basis))
    more = ["area", "extrinsic", Radial()]  # named: the network's channels are picked from them
    D = opnet.encode(coll.mesh(i), coll.base_basis, channels=more)
    np.testing.assert_allclose(opnet.decode(net, D, more), X, rtol=1e-5, atol=1e-6)


def test_the_torch_side_old_names_work_and_warn_once(coll, monkeypatch):
    import warnings

    from opnet import _deprecation

    net = opnet.OperatorNet(coll.vertices.shape[1], k=coll.base_basis.k, channels=("extrinsic",))
    ops = coll.operators[:2]
    module = opnet.torch_ops.ShapeDifferences(coll.base_basis, ("area",))
    calls = {
        "decode": (lambda: opnet.decode(net, ops, kinds=opnet.KINDS), lambda: opnet.decode(net, ops, opnet.KINDS)),
        "ShapeDifferences": (
            lambda: opnet.torch_ops.ShapeDifferences(coll.base_basis, kinds=("area",)).channels,
            lambda: opnet.torch_ops.ShapeDifferences(coll.base_basis, channels=("area",)).channels,
        ),
        "ShapeDifferences.kinds": (lambda: module.kinds, lambda: module.channels),
    }
    for name, (old, new) in calls.items():
        monkeypatch.setattr(_deprecation, "WARNED", set())
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            got = [old(), old()]
            expected = new()
        warned = [w for w in caught if issubclass(w.category, DeprecationWarning)]
        assert len(warned) == 1 and "deprecated" in str(warned[0].message), (name, [str(w.message) for w in warned])
        for g in got:
            np.testing.assert_array_equal(np.asarray(g), np.asarray(expected))
    with pytest.raises(TypeError, match="both channels="):
        opnet.decode(net, ops, channels=opnet.KINDS, kinds=opnet.KINDS)


# ------------------------------------------------------------------------------------------------------------------
# the command line


@pytest.mark.slow
def test_the_command_line_imports_a_module_class(stored, radial_module, tmp_path):
    manifest = save_collection(stored, tmp_path / "data" / "tiny")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.dirname(radial_module.__file__), *sys.path]))
    run = tmp_path / "run"
    common = ["--collection", str(manifest), "--epochs", "1", "--hidden", "16", "--batch-size", "8"]

    def cli(*args):
        return subprocess.run([sys.executable, "-m", "opnet", *args], capture_output=True, text=True, env=env)

    out = cli("train", *common, "--channels", "area,radial_channels:RadialArea", "--run-dir", str(run))
    assert out.returncode == 0, out.stderr
    assert train.load_model(run).channels == ("area", "radial area")
    assert list((tmp_path / "data").glob("tiny.channel.radial_area.*.npz"))  # cached beside the collection
    out = cli("evaluate", "--run-dir", str(run), "--collection", str(manifest), "--json", str(tmp_path / "e.json"))
    assert out.returncode == 0, out.stderr
    rows = json.loads((tmp_path / "e.json").read_text())
    assert {r["method"] for r in rows} == {
        "OperatorNet (Area+radial area)",
        "Nearest neighbour (Area+radial area)",
        "Base shape",
    }
    bad = cli("train", *common, "--channels", "area,nowhere_pkg:MyIP", "--run-dir", str(tmp_path / "bad"))
    assert bad.returncode == 1 and "the module 'nowhere_pkg' does not import" in bad.stderr
    bad = cli("train", *common, "--channels", "area,volume", "--run-dir", str(tmp_path / "bad"))
    assert bad.returncode == 1 and "unknown channel 'volume'" in bad.stderr


def test_results_of_before_keep_loading():
    """Rows written before channels were lists (a comma-joined string) still fill the ablation's table."""
    from opnet import reproduce

    old = [{"table": "ablation", "method": "OperatorNet (A+E) depth 2", "channels": "area,extrinsic", "depth": 2}]
    new = [{"table": "ablation", "method": "OperatorNet (A+E) depth 2", "channels": ["extrinsic", "area"], "depth": 2}]
    for rows in (old, new):
        table = reproduce.ablation_table([dict(r, d_R=3e-4) for r in rows])
        assert table[1, list(reproduce.ABLATION_SETS).index("A+E")] == pytest.approx(3.0)
        assert np.isnan(table).sum() == table.size - 1


def test_a_table1_of_before_renders_one_line_per_method():
    """A results.json of before (rows named by ``method`` only, no ``run`` or ``baseline``) keeps its rows apart,
    with the paper's numbers and the targets, as the reproduction of then wrote them."""
    from opnet.experiments.report import results_markdown

    names = ["OperatorNet (Int+Ext)", "OperatorNet ours (Int+Ext)", "Nearest neighbour (Int+Ext)", "Base shape"]
    metrics = dict(n_shapes=4, seconds_per_shape=0.1, d_R_median=1e-4, d_V=0.1, d_E=0.1, train_seconds=None)
    rows = [
        dict(table="table1", method=m, channels="area,conformal,extrinsic", depth=1, split="test", d_R=(i + 1) * 1e-4)
        | metrics
        for i, m in enumerate([*names, "a method of one's own"])
    ]
    budget = dict(lr=1e-3, batch_size=32, epochs=1, ablation_epochs=1)
    text = results_markdown(
        rows, dict(preset="quick", machine="m", collection="c", eval_subset=4, budget=budget, wall_seconds=1.0)
    )
    table1 = text[text.index("## Table 1") :].split("\n## ")[0]  # the section's own lines, not the claims table's
    lines = [line for line in table1.splitlines() if line.startswith("| ") and "test: d_R" not in line]
    assert [line.split(" | ")[0][2:] for line in lines] == [*names, "a method of one's own"]
    assert lines[0].split(" | ")[4] == "1.11"  # the paper's d_R beside the paper's network
    assert "NN's d_R / OperatorNet (Int+Ext)'s = 3 (" in text and "d_R / ours = 0.5 (" in text


def test_digests_are_the_same_in_every_process_and_see_a_subclass_code(tmp_path):
    """A dataclass inner product (whose class holds objects that print their address) and a frozenset parameter give
    one digest in two processes; a subclass of a built-in is identified by its own code, not the built-in's version."""
    (tmp_path / "dc_channels.py").write_text(
        "import dataclasses\nimport opnet\n\n\n@dataclasses.dataclass\nclass Heat(opnet.AreaInnerProduct):\n"
        "    t: float = 1.0\n    tags: frozenset = frozenset({'a', 'b', 'c'})\n    name = 'heat area'\n"
    )
    code = "import dc_channels, opnet; print(opnet.channel_digest(dc_channels.Heat()))"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), *sys.path]))
    digests = {
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=dict(env, PYTHONHASHSEED=s)
        ).stdout.strip()
        for s in ("1", "2")
    }
    assert len(digests) == 1 and len(next(iter(digests))) == 16

    def doubled(factor):
        space = {}
        exec(
            "import opnet\nclass MyArea(opnet.AreaInnerProduct):\n    name = 'my area'\n"
            f"    def project(self, v, f, e):\n        return {factor} * super().project(v, f, e)\n",
            space,
        )
        return space["MyArea"]()

    assert opnet.channel_digest(doubled(2)) != opnet.channel_digest(doubled(3))
    with pytest.raises(ChannelError, match="short name of a set of built-in channels"):
        opnet.get_inner_product(type("E", (opnet.ExtrinsicInnerProduct,), {"name": "Ext"})())
