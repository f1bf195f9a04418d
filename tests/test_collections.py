"""Collection storage (atomic, checksummed), splits, the evaluation subset and the user-folder loader,
on toy shapes so that these tests need no body model."""

import hashlib
import json
import multiprocessing as mp
import os
import signal
import time
import warnings

import numpy as np
import pytest
import trimesh

import opnet
from opnet.data import CollectionError, toy


@pytest.fixture(scope="module")
def coll(toy_collection):
    return toy_collection()


def test_collection_fields(coll):
    N, n = len(coll), coll.faces.max() + 1
    assert coll.vertices.shape == (N, n, 3) and coll.vertices.dtype == np.float32
    assert coll.operators.shape == (N, 3, 20, 20) and coll.operators.dtype == np.float32
    np.testing.assert_allclose(
        coll.operators[5, 0], opnet.shape_difference(coll.base_basis, coll.mesh(5), "area"), atol=1e-5
    )
    assert set(coll.split) == {"train", "val", "test", "test_subjects"}


def test_splits_hold_out_whole_subcollections_and_subjects(coll):
    for held in ("test", "val", "test_subjects"):
        held_sc = set(coll.subcollection[coll.split == held])
        assert held_sc.isdisjoint(coll.subcollection[coll.split == "train"])
    unseen = set(coll.subjects("test_subjects"))
    seen = set(coll.subject[coll.split != "test_subjects"])
    assert unseen and unseen.isdisjoint(seen)
    assert len(set(coll.subcollection[coll.split == "test"])) == 2
    s = coll.subjects()[0]
    walk = coll.sequence(s, "bend")
    assert len(walk) and np.all(coll.subcollection[walk] == f"{s}/bend") and np.all(np.diff(walk) > 0)
    with pytest.raises(ValueError, match=f"subject '{s}' has no sequence 'moonwalk'; it has .*'{s}/bend'"):
        coll.sequence(s, "moonwalk")


def test_evaluation_subset_is_furthest_point_per_test_subcollection(coll):
    sub = coll.eval_subset
    assert (coll.split[sub] == "test").all()
    assert len(sub) == 2 * 2  # 2 test sub-collections × 2 shapes
    # the second pick of each sub-collection is the shape furthest from its first frame
    for sc in set(coll.subcollection[sub]):
        members = np.flatnonzero(coll.subcollection == sc)
        d = [opnet.data.hausdorff(coll.vertices[members[0]], coll.vertices[m]) for m in members]
        assert members[int(np.argmax(d))] in sub


def test_save_and_read_round_trip(coll, tmp_path):
    path = opnet.data.save_collection(coll, tmp_path / "toy")
    back = opnet.data.read_collection(path, expected_meta={"seed": 0})
    np.testing.assert_array_equal(back.vertices, coll.vertices)
    np.testing.assert_array_equal(back.operators, coll.operators)
    np.testing.assert_array_equal(back.split, coll.split)
    np.testing.assert_array_equal(back.base_basis.evecs, coll.base_basis.evecs)
    np.testing.assert_array_equal(back.subject, coll.subject)
    np.testing.assert_array_equal(back.params["group"], coll.params["group"])
    manifest = json.loads(path.read_text())
    assert manifest["shapes"]["operators"] == list(coll.operators.shape)
    assert (tmp_path / manifest["data"]).is_file() and manifest["data"].startswith("toy.")


def test_corrupt_mismatched_and_unfinished_files_get_clear_errors(coll, tmp_path):
    path = opnet.data.save_collection(coll, tmp_path / "toy")
    with pytest.raises(CollectionError, match="seed=0, expected 1.*rebuild=True"):
        opnet.data.read_collection(path, expected_meta={"seed": 1})
    data = next(tmp_path.glob("toy.*.npz"))
    raw = bytearray(data.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    data.write_bytes(bytes(raw))
    with pytest.raises(CollectionError, match="checksum"):
        opnet.data.read_collection(path)
    path.write_text("[]")
    with pytest.raises(CollectionError, match="not an opnet manifest"):
        opnet.data.read_collection(path)
    path.unlink()
    with pytest.raises(CollectionError, match="interrupted"):
        opnet.data.read_collection(path)
    with pytest.raises(CollectionError, match="no collection"):
        opnet.data.read_collection(tmp_path / "other")


def _killed_midway_save(coll, path):
    """Save a collection but stall half-way through writing its arrays, so it can be killed there."""

    def half_then_stall(f, **arrays):
        f.write(b"PK\x03\x04" + bytes(4096))  # the start of a zip archive, then nothing
        f.flush()
        time.sleep(60)

    np.savez = half_then_stall
    opnet.data.save_collection(coll, path)


def _kill_midway(coll, target, tmp_path):
    proc = mp.get_context("fork").Process(target=_killed_midway_save, args=(coll, target))
    proc.start()
    deadline = time.time() + 20
    while not list(tmp_path.glob(f".{target.name}.tmp-*")) and time.time() < deadline:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)  # killed while writing its data
    proc.join()
    assert list(tmp_path.glob(f".{target.name}.tmp-*"))  # it did die mid-write


def test_a_killed_build_leaves_nothing_that_loads(coll, tmp_path):
    first = tmp_path / "first"
    _kill_midway(coll, first, tmp_path)
    with pytest.raises(CollectionError, match="interrupted"):
        opnet.data.read_collection(first)  # an interrupted first build: nothing loads
    opnet.data.save_collection(coll, first)  # a finished save works and clears the debris
    assert len(opnet.data.read_collection(first)) == len(coll)
    assert not list(tmp_path.glob(".first.tmp-*"))


def test_a_killed_rebuild_keeps_the_previous_collection(coll, tmp_path):
    target = tmp_path / "again"
    opnet.data.save_collection(coll, target)
    _kill_midway(coll, target, tmp_path)
    back = opnet.data.read_collection(target)  # the previous complete collection, never the half-written one
    np.testing.assert_array_equal(back.operators, coll.operators)


def test_rewrites_leave_one_data_file(coll, tmp_path, toy_collection):
    small = toy_collection(n_subjects=3)
    opnet.data.save_collection(coll, tmp_path / "c")
    opnet.data.save_collection(small, tmp_path / "c")
    assert len(list(tmp_path.glob("c.*.npz"))) == 1
    assert len(opnet.data.read_collection(tmp_path / "c")) == len(small)


def test_torch_dataset(coll):
    pytest.importorskip("torch")
    ds = opnet.data.OperatorDataset(coll, "train", channels=("area", "extrinsic"))
    ops, verts = ds[0]
    assert ops.shape == (2, 20, 20) and verts.shape == (coll.vertices.shape[1], 3)
    assert str(ops.dtype) == "torch.float32"
    np.testing.assert_allclose(ops[1].numpy(), coll.operators[coll.indices("train")[0], 2])
    assert len(ds) == len(coll.indices("train"))
    with pytest.raises(ValueError, match="channels"):
        opnet.data.OperatorDataset(coll, "train", channels=("volume",))


def test_user_folder_loader(tmp_path):
    base = toy.capsule("quick")
    folder = tmp_path / "mine"
    folder.mkdir()
    for i, angle in enumerate([0.0, 0.5, 1.0, 1.5]):
        trimesh.Trimesh(toy.bend(base.vertices, angle), base.faces, process=False).export(folder / f"pose{i}.ply")
    (folder / "splits.csv").write_text("filename,split,subcollection\npose3.ply,test,pose3\npose2.ply,val,pose2\n")
    (folder / "._pose0.ply").write_bytes(b"macOS metadata, not a mesh")
    coll = opnet.data.load_folder(folder, k=15, progress=False)
    assert len(coll) == 4 and list(coll.split) == ["train", "train", "val", "test"]
    np.testing.assert_allclose(coll.operators[0, 0], np.eye(15), atol=1e-5)  # the first file is the base
    assert list(coll.eval_subset) == [3] and coll.meta["name"] == "mine"
    by_stem = opnet.data.load_folder(folder, base="pose1", k=15, progress=False)
    np.testing.assert_allclose(by_stem.operators[1, 0], np.eye(15), atol=1e-5)
    np.testing.assert_allclose(coll.vertices[2], toy.bend(base.vertices, 1.0), atol=1e-6)
    back = opnet.data.read_collection(opnet.data.save_collection(coll, tmp_path / "mine"))
    np.testing.assert_array_equal(back.params["filename"], ["pose0.ply", "pose1.ply", "pose2.ply", "pose3.ply"])
    assert list(back.subject) == list(back.subcollection) == ["pose0", "pose1", "pose2", "pose3"]
    (folder / "splits.csv").write_text("pose2.ply,test,walk-a,ann\npose3.ply,test,walk-b,ann\n")  # with subjects
    people = opnet.data.load_folder(folder, k=15, progress=False)
    assert people.subjects() == ["ann", "pose0", "pose1"] and people.subjects("test") == ["ann"]
    assert list(people.sequence("ann")) == [2, 3] and list(people.sequence("ann", "walk-b")) == [3]
    with pytest.raises(ValueError, match="no subject 'bob'.*'ann'"):
        people.sequence("bob")
    (folder / "splits.csv").write_text("pose2.ply,test_subjects,walk-a,ann\npose3.ply,train,walk-b,ann\n")
    with pytest.raises(CollectionError, match=r"subjects \['ann'\] have shapes in 'test_subjects' and in other"):
        opnet.data.load_folder(folder, k=15, progress=False)
    (folder / "splits.csv").write_text("pose2.ply,test,walk-a,\n")
    with pytest.raises(CollectionError, match="no empty field"):
        opnet.data.load_folder(folder, k=15, progress=False)
    other = toy.capsule("default")
    trimesh.Trimesh(other.vertices, other.faces, process=False).export(folder / "pose9.ply")
    with pytest.raises(CollectionError, match="pose9.ply has other faces"):
        opnet.data.load_folder(folder)
    (folder / "pose9.ply").unlink()
    (folder / "splits.csv").write_text("pose3.ply,holdout,x\n")
    with pytest.raises(CollectionError, match="splits.csv:1"):
        opnet.data.load_folder(folder)
    (folder / "splits.csv").write_text("pose3.ply,test,x\npose3.ply,val,x\n")
    with pytest.raises(CollectionError, match="splits.csv:2"):
        opnet.data.load_folder(folder)
    (folder / "splits.csv").write_text("pose3.ply,test,seq\npose0.ply,train,seq\n")
    with pytest.raises(CollectionError, match="spans the splits"):
        opnet.data.load_folder(folder)


def test_determinism(toy_collection):
    a, b = toy_collection(seed=3), toy_collection(seed=3)
    np.testing.assert_array_equal(a.split, b.split)
    np.testing.assert_array_equal(a.operators, b.operators)
    assert not np.array_equal(a.split, toy_collection(seed=4).split)


def test_damaged_manifests_and_data_files_are_named(coll, tmp_path):
    """A manifest whose data entry leaves its folder or is no file name, and a data file whose checksum was
    updated to match damaged contents, each get an error naming the file and rebuild=True."""
    path = opnet.data.save_collection(coll, tmp_path / "toy")
    manifest = json.loads(path.read_text())
    for entry in ("../elsewhere.npz", "/etc/passwd", 5, None, ["toy.npz"]):
        path.write_text(json.dumps(dict(manifest, data=entry)))
        with pytest.raises(CollectionError, match=r"toy\.json.*data file.*rebuild=True"):
            opnet.data.read_collection(path)
    data = tmp_path / manifest["data"]
    with np.load(data) as z:  # every array present, one of them cut short
        cut = {key: z[key][:1] if key == "operators" else z[key] for key in z.files}
    for contents in (b"not a zip archive at all", _npz_bytes(vertices=np.zeros(3)), _npz_bytes(**cut)):
        data.write_bytes(contents)
        fake = hashlib.sha256(contents).hexdigest()  # the checksum made to match the damage
        path.write_text(json.dumps(dict(manifest, sha256=fake)))
        with pytest.raises(CollectionError, match=rf"{data.name}.*cannot be read.*rebuild=True"):
            opnet.data.read_collection(path)


def _npz_bytes(**arrays) -> bytes:
    import io

    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def test_user_folder_oddities(tmp_path):
    """A subfolder named like a mesh is not a mesh; a splits.csv that is not text is named."""
    base = toy.capsule("quick")
    folder = tmp_path / "mine"
    folder.mkdir()
    for i, angle in enumerate([0.0, 0.5]):
        trimesh.Trimesh(toy.bend(base.vertices, angle), base.faces, process=False).export(folder / f"pose{i}.ply")
    (folder / "archive.ply").mkdir()
    assert len(opnet.data.load_folder(folder, k=10, progress=False)) == 2
    (folder / "splits.csv").write_bytes(b"\xff\xfe\x00binary\x00")
    with pytest.raises(CollectionError, match="splits.csv is not UTF-8 text"):
        opnet.data.load_folder(folder, k=10, progress=False)


def _generator_of(coll, built: list, started=None, release=None):
    """A stand-in for a collection's generator: ``coll``'s arrays under the meta it is asked for, each call's preset
    appended to ``built``; with events, it sets ``started`` and waits for ``release`` before it returns."""
    from opnet.data import storage

    fields = ("vertices", "faces", "operators", "split", "subcollection", "subject", "base_basis", "eval_subset")

    def generate(preset, resolution, seed, meta, progress=None):
        built.append(preset)
        if started is not None:
            started.set()
            assert release.wait(30)
        return storage.Collection(**{f: getattr(coll, f) for f in (*fields, "params")}, meta=dict(meta))

    return generate


def test_an_unusable_data_root_is_found_before_building(coll, tmp_path, monkeypatch):
    """A data root that is a file, inside a file, or on a full disk is refused before the (minutes long) build;
    a save that fails after the build returns the built collection with a warning instead of losing it."""
    from opnet.data import generators, storage

    built = []
    fake_generate = _generator_of(coll, built)
    monkeypatch.setitem(generators.GENERATORS, "humans", (fake_generate, ("1k",)))
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder")
    for root in (a_file, a_file / "inside"):
        with pytest.raises(CollectionError, match="data root.*OPNET_DATA_DIR"):
            opnet.data.load_collection("humans", "quick", root)
    monkeypatch.setattr(storage.shutil, "disk_usage", lambda p: storage.shutil._ntuple_diskusage(1, 1, 0))
    with pytest.raises(CollectionError, match="free"):
        opnet.data.load_collection("humans", "quick", tmp_path / "full")
    assert built == []  # refused before building
    monkeypatch.undo()
    monkeypatch.setitem(generators.GENERATORS, "humans", (fake_generate, ("1k",)))

    def no_space(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(storage, "save_collection", no_space)
    with pytest.warns(UserWarning, match="could not be saved.*No space left"):
        got = opnet.data.load_collection("humans", "quick", tmp_path / "ok")
    assert built == ["quick"] and len(got) == len(coll)


def test_the_manifest_records_the_channels(coll, tmp_path):
    """The manifest names the operators' channels in order, with their digests; a manifest whose channels do not
    fit the stored operators is refused, one written before channels were recorded reads as opnet.KINDS."""
    path = opnet.data.save_collection(coll, tmp_path / "toy")
    manifest = json.loads(path.read_text())
    assert manifest["channels"] == list(opnet.KINDS)
    assert manifest["channel_digests"] == {c: opnet.channel_digest(c) for c in opnet.KINDS}
    swapped = opnet.data.read_collection(path)
    assert swapped.channels == opnet.KINDS
    path.write_text(json.dumps(dict(manifest, channels=["extrinsic", "area"])))
    with pytest.raises(CollectionError, match=r"names the channels \['extrinsic', 'area'\].*rebuild=True"):
        opnet.data.read_collection(path)
    old = {k: v for k, v in manifest.items() if k not in ("channels", "channel_digests")}
    path.write_text(json.dumps(old))
    assert opnet.data.read_collection(path).channels == opnet.KINDS


def test_a_format_2_collection_is_read_with_its_subjects_derived(coll, tmp_path):
    """Collections cached before the subject array (format 2, no channel order recorded) load as they were, each
    shape's subject taken from its sub-collection's name; another format is refused with how to make it again."""
    from opnet.data import storage

    stem = tmp_path / "old"
    manifest = json.loads(opnet.data.save_collection(coll, stem).read_text())
    with np.load(stem.with_name(manifest["data"])) as z:
        arrays = {k: z[k] for k in z.files if k != "subject"}
    stem.with_name(manifest["data"]).unlink()
    tmp = tmp_path / "old.npz.tmp"
    with open(tmp, "wb") as f:
        np.savez(f, **arrays)
    digest = storage._sha256(tmp)
    data = tmp.rename(tmp_path / f"old.{digest[:12]}.npz")
    del manifest["channels"], manifest["shapes"]["subject"]
    old = dict(manifest, format_version=2, data=data.name, sha256=digest)
    stem.with_name("old.json").write_text(json.dumps(old))
    back = opnet.data.read_collection(stem)
    np.testing.assert_array_equal(back.subject, coll.subject)
    np.testing.assert_array_equal(back.operators, coll.operators)
    stem.with_name("old.json").write_text(json.dumps(dict(old, format_version=1)))
    with pytest.raises(CollectionError, match="format 1.*reads 2 and 3.*rebuild=True"):
        opnet.data.read_collection(stem)


def test_make_splits_holds_out_the_subjects_it_is_told():
    rng = np.random.default_rng(0)
    subjects = np.repeat(np.arange(6), 8)
    groups = np.tile(np.repeat(["a", "b", "c", "d"], 2), 6)
    split = opnet.data.make_splits(subjects, groups, rng, n_test_subcollections=2, n_test_subjects=1, unseen=[4])
    held = set(subjects[split == "test_subjects"])
    assert 4 in held and len(held) == 2
    with pytest.raises(ValueError, match=r"unseen subjects \[7\]"):
        opnet.data.make_splits(subjects, groups, rng, unseen=[7])
    names = np.array(["ab", "cd", "ef", "gh"]).repeat(8)  # fixed-width strings: a longer name is not cut to fit
    with pytest.raises(ValueError, match="abc"):
        opnet.data.make_splits(names, groups[: len(names)], rng, unseen=["abc"])


@pytest.mark.parametrize("preset", ["quick", "default", "paper"])
def test_the_animals_bodies_have_distinct_names_and_hold_out_the_unseen_species(preset):
    from opnet.data.animals import PRESETS, UNSEEN_SPECIES, body_design

    species = ["horse", "alpaca", "bull", "cow", "deer", "donkey", "fox", "husky", "shibainu", "stag", "wolf"]
    p = PRESETS[preset]
    for seed in range(20):  # before names were redrawn, 6 of these 20 seeds named two paper bodies alike
        weights, names, held = body_design(species, preset, np.random.default_rng(seed))
        assert len(set(names)) == len(names) == len(weights) == len(species) + p.blends + p.unseen_blends
        assert np.allclose(weights.sum(1), 1) and ((weights > 0).sum(1) <= 2).all()
        with_unseen = np.flatnonzero(weights[:, species.index(UNSEEN_SPECIES)] > 0)
        assert set(with_unseen) <= set(held) and len(held) == len(with_unseen) + p.test_blends


def test_with_training_from_adds_training_shapes_only(coll):
    other = coll.subset(np.arange(len(coll)))  # the same shapes, encoded otherwise
    other.operators = other.operators * np.float32(1.01)
    both = coll.with_training_from(other)
    train, held = coll.indices("train"), coll.split != "train"
    assert len(both) == len(coll) + len(train)
    np.testing.assert_array_equal(both.indices("train"), np.r_[train, len(coll) + np.arange(len(train))])
    np.testing.assert_array_equal(both.operators[len(coll) :], other.operators[train])
    np.testing.assert_array_equal(both.vertices[len(coll) :], coll.vertices[train])
    for split in ("val", "test", "test_subjects"):  # the held-out splits and the evaluation subset: coll's own
        np.testing.assert_array_equal(both.indices(split), coll.indices(split))
    np.testing.assert_array_equal(both.eval_subset, coll.eval_subset)
    assert held.sum() == (both.split != "train").sum() and coll.with_training_from() is coll
    smaller = coll.subset(train)
    smaller.base_basis = coll.base_basis.truncate(10)  # another basis
    with pytest.raises(ValueError, match="same base shape, basis size"):
        coll.with_training_from(smaller)
    with pytest.raises(TypeError, match="must be opnet.data.Collection"):
        coll.with_training_from(coll.operators)


# -- one name for the operators' channels: ``channels``; the old ``kinds`` still works and warns once ----------------


def _deprecations(call, monkeypatch):
    """``call()`` twice in what is, for opnet, a fresh process (its memory of the old names that warned cleared):
    both results and the DeprecationWarnings.
    """
    from opnet import _deprecation

    monkeypatch.setattr(_deprecation, "WARNED", set())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # Python's own once-per-line filter is not what is tested
        first, second = call(), call()
    return first, second, [w for w in caught if issubclass(w.category, DeprecationWarning)]


@pytest.mark.parametrize(
    "old, new",
    [
        (lambda c: c.kinds, lambda c: c.channels),
        (
            lambda c: c.with_kinds(["extrinsic", "area"]).channels,
            lambda c: c.with_channels(["extrinsic", "area"]).channels,
        ),
        (lambda c: c.with_kinds(kinds=["area"]).channels, lambda c: c.with_channels(channels=["area"]).channels),
        (
            lambda c: opnet.shape_differences(c.base_basis, c.vertices[:2], kinds=["area"]),
            lambda c: opnet.shape_differences(c.base_basis, c.vertices[:2], channels=["area"]),
        ),
        (
            lambda c: opnet.encode(c.mesh(0), c.base_basis, kinds=["area"]),
            lambda c: opnet.encode(c.mesh(0), c.base_basis, channels=["area"]),
        ),
        (
            lambda c: opnet.inner_products.get_inner_products(kinds=["area"])[0].name,
            lambda c: opnet.inner_products.get_inner_products(channels=["area"])[0].name,
        ),
        (
            lambda c: _rebuilt(c, kinds=c.channels).channels,
            lambda c: _rebuilt(c, channels=c.channels).channels,
        ),
    ],
    ids=[
        "Collection.kinds",
        "with_kinds",
        "with_kinds(kinds=)",
        "shape_differences",
        "encode",
        "get_inner_products",
        "Collection(kinds=)",
    ],
)
def test_the_old_name_kinds_works_and_warns_once(coll, monkeypatch, old, new):
    first, second, warned = _deprecations(lambda: old(coll), monkeypatch)
    assert len(warned) == 1, [str(w.message) for w in warned]
    assert "deprecated" in str(warned[0].message) and "channels" in str(warned[0].message)
    assert warned[0].filename == __file__  # attributed to the caller's line, not to opnet
    expected, again, quiet = _deprecations(lambda: new(coll), monkeypatch)
    assert quiet == []  # the new names never warn
    for got in (first, second, again):
        np.testing.assert_array_equal(np.asarray(got), np.asarray(expected))


def _rebuilt(coll, **channels):
    return opnet.data.Collection(
        coll.vertices,
        coll.faces,
        coll.operators,
        coll.split,
        coll.subcollection,
        coll.subject,
        coll.base_basis,
        coll.eval_subset,
        **channels,
    )


def test_the_old_and_the_new_keyword_together_are_refused(coll):
    with pytest.raises(TypeError, match=r"both channels= and its deprecated name kinds="):
        opnet.shape_differences(coll.base_basis, coll.vertices[:1], channels=["area"], kinds=["area"])
    with pytest.raises(TypeError, match=r"Collection\(\) got both channels= and its deprecated name kinds="):
        _rebuilt(coll, channels=coll.channels, kinds=coll.channels)
    with pytest.raises(TypeError, match="both channels="):
        opnet.encode(coll.mesh(0), coll.base_basis, channels=["area"], kinds=["area"])


def test_a_collection_names_its_channels(coll):
    assert coll.channels == opnet.KINDS and "channels=('area', 'conformal', 'extrinsic')" in repr(coll)
    assert "kinds" not in repr(coll)
    positional = opnet.data.Collection(
        coll.vertices,
        coll.faces,
        coll.operators[:, :1],
        coll.split,
        coll.subcollection,
        coll.subject,
        coll.base_basis,
        coll.eval_subset,
        {},
        {},
        ("area",),
    )
    assert positional.channels == ("area",)


def test_a_second_loader_waits_for_the_builder_and_reads_its_collection(coll, tmp_path, monkeypatch):
    """Two loaders of one collection on a cold cache (two test workers, a notebook beside a script): the second waits
    for the first's build (a lock beside the files) and reads the saved collection instead of building it again. A
    thread waits on the lock like another process."""
    import threading

    from opnet.data import generators

    built, started, release = [], threading.Event(), threading.Event()
    monkeypatch.setitem(generators.GENERATORS, "humans", (_generator_of(coll, built, started, release), ("1k",)))
    got = {}
    first = threading.Thread(
        target=lambda: got.setdefault("first", opnet.data.load_collection("humans", "quick", tmp_path))
    )
    first.start()
    assert started.wait(30)  # the first is building, holding the lock
    second = threading.Thread(
        target=lambda: got.setdefault("second", opnet.data.load_collection("humans", "quick", tmp_path))
    )
    with pytest.warns(UserWarning, match="waiting for another process.*humans collection") as said:
        second.start()
        deadline = time.time() + 30
        while not any("waiting for another" in str(w.message) for w in said) and time.time() < deadline:
            time.sleep(0.01)  # until the second is waiting on the lock
        release.set()
        first.join(30)
        second.join(30)
    assert not first.is_alive() and not second.is_alive()
    assert built == ["quick"]  # one build
    np.testing.assert_array_equal(got["second"].vertices, got["first"].vertices)
    assert got["second"].meta == got["first"].meta
