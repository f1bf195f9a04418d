"""Evaluation (methods × metrics × test sets) and the reproduction pipeline."""

import pytest

pytest.importorskip("torch")  # the net extra: skipped by a core-only install

import dataclasses
import json

import numpy as np

import opnet
import opnet.plotting
from opnet import evaluate, reproduce, train
from opnet.data import toy
from opnet.experiments import claims, report
from opnet.experiments.baselines import FUNCCHAR_INT
from opnet.experiments.report import MAPPED_GROUPS, headline_markdown, row_identity
from opnet.experiments.steps import DISCRETISATIONS


@pytest.fixture(scope="module")
def coll(tiny_collection):
    return tiny_collection()


def test_nearest_neighbour_is_the_brute_force_argmin(coll):
    idx = coll.indices("test")
    for channels in (opnet.KINDS, ("extrinsic",), ("area", "conformal")):
        chans = [opnet.KINDS.index(c) for c in channels]
        train_idx = coll.indices("train")
        brute = [
            train_idx[
                np.argmin(
                    [
                        np.linalg.norm(coll.operators[i][chans].astype(float) - coll.operators[j][chans].astype(float))
                        for j in train_idx
                    ]
                )
            ]
            for i in idx
        ]
        assert list(evaluate.nearest_neighbour(coll, idx, channels, chunk=3)) == brute
    # a training shape's nearest neighbour is itself: zero error
    m = evaluate.nearest_neighbour_method(coll)
    t = coll.indices("train")[:5]
    np.testing.assert_allclose(m.reconstruct(t), coll.vertices[t])


def test_rows_hold_each_method_and_test_set_with_the_paper_metrics(coll):
    methods = [evaluate.base_shape_method(coll), evaluate.nearest_neighbour_method(coll, ("extrinsic",))]
    rows = evaluate.evaluate(coll, methods, extra={"preset": "tiny"})
    assert [(r["method"], r["split"]) for r in rows] == [
        (m.name, s) for m in methods for s in ("eval_subset", "test", "test_subjects")
    ]
    assert rows[0]["method"] == "Base shape" and rows[3]["method"] == "Nearest neighbour (Ext)"
    base = rows[1]
    idx = coll.indices("test")
    gt, rec = coll.vertices[idx], np.broadcast_to(coll.base_basis.mesh.vertices, (len(idx), *coll.vertices.shape[1:]))
    assert np.isclose(base["d_R"], opnet.d_R(gt, rec).mean())
    assert np.isclose(base["d_E_median"], np.median(opnet.d_E(gt, rec, coll.faces)))
    assert np.isclose(base["d_V"], opnet.d_V(gt, rec, coll.faces).mean())
    assert base["n_shapes"] == 4 and base["preset"] == "tiny"


def test_sfl_recovers_edge_lengths_from_the_full_laplacian(coll):
    """Shape-from-Laplacian is given each shape's full Laplacian: its edge lengths come back (d_E far below the base
    shape's), its rows carry baseline "sfl", and a collection on other faces is refused."""
    sfl = evaluate.sfl_method(coll, max_shapes=2)
    rows = evaluate.evaluate(coll, [sfl, evaluate.base_shape_method(coll)], test_sets=("test",))
    assert [r["baseline"] for r in rows] == ["sfl", "base_shape"] and rows[0]["n_shapes"] == 2
    assert rows[0]["d_E"] < 0.05 * rows[1]["d_E"], rows
    other = dataclasses.replace(coll, faces=coll.faces[:, ::-1].copy())
    with pytest.raises(ValueError, match="shapes are on other faces"):
        evaluate.sfl_method(other)


def test_d_V_is_nan_on_open_meshes():
    base = toy.capsule("quick")
    keep = np.flatnonzero(base.vertices[base.faces].mean(1)[:, 2] < 1.0)  # cut off a cap
    gt = base.vertices[None]
    err = evaluate.shape_errors(gt, gt * 1.1, base.faces[keep])
    assert np.isnan(err["d_V"]).all() and np.isfinite(err["d_E"]).all()


def test_vertex_errors_ignore_rigid_motions(coll):
    from scipy.spatial.transform import Rotation

    X = coll.vertices[:2].astype(float)
    moved = X @ Rotation.from_euler("xyz", [0.3, -1, 2]).as_matrix().T + 5.0
    assert np.abs(evaluate.vertex_errors(X, moved)).max() < 1e-9


def test_channel_labels():
    assert evaluate.channel_label(opnet.KINDS) == "Int+Ext"
    assert evaluate.channel_label(("conformal", "area")) == "Int"
    assert evaluate.channel_label("extrinsic") == "Ext"
    assert evaluate.channel_label("area,extrinsic") == "A+E"


def test_operatornet_method_decodes_its_channels(coll):
    net, _ = train.fit(coll, channels="E+C", epochs=2, hidden=32, progress=False)
    m = evaluate.operatornet_method(net, coll)
    assert m.name == "OperatorNet (E+C)" and m.channels == ("conformal", "extrinsic")
    idx = coll.indices("test")
    expected = evaluate.predict(net, coll.operators[idx][:, [1, 2]])
    np.testing.assert_array_equal(m.reconstruct(idx), expected)


def test_the_notebooks_share_a_folder_whose_runs_carry_their_budget(tiny_collection, tmp_path, monkeypatch):
    import dataclasses

    first = reproduce.notebook_out("quick", tmp_path)
    assert first == tmp_path / "reproduce-quick" and reproduce.notebook_out("default", tmp_path) != first
    coll = tiny_collection()
    coll.meta["preset"] = "quick"  # a generated collection's preset names its budget
    run = reproduce.run_path(first, coll, "table1", opnet.KINDS)
    assert run.parent == first / "runs" and run.name.startswith("table1-A+E+C-d1-")
    base = reproduce.BUDGETS["quick"]
    monkeypatch.setitem(reproduce.BUDGETS, "quick", dataclasses.replace(base, analogies=7))
    assert reproduce.run_path(first, coll, "table1", opnet.KINDS) == run  # how many questions are asked trains nothing
    # a release that changes the training budget trains beside the old runs (which would refuse other settings)
    monkeypatch.setitem(reproduce.BUDGETS, "quick", dataclasses.replace(base, epochs=base.epochs + 1))
    assert reproduce.run_path(first, coll, "table1", opnet.KINDS) != run
    monkeypatch.setitem(reproduce.BUDGETS, "quick", dataclasses.replace(base, schedule="constant"))
    assert reproduce.run_path(first, coll, "table1", opnet.KINDS) != run
    monkeypatch.setenv("OPNET_DATA_DIR", str(tmp_path / "data"))
    assert reproduce.notebook_out("paper").parent == tmp_path / "data"
    with pytest.raises(ValueError, match="unknown preset 'fast'"):
        reproduce.notebook_out("fast")


@pytest.mark.slow
def test_reproduce_writes_complete_results_and_resumes(tmp_path, profile_loads, tiny_collection):
    tiny = tiny_collection("humans")
    profile_loads("humans", tiny)
    budget = reproduce.Budget(epochs=2, ablation_epochs=1, batch_size=8, hidden=16, refine_steps=5, refine_shapes=3)
    options = dict(budget=budget, device="cpu", progress=False, applications=False, maps=False)
    rows = reproduce.reproduce("quick", tmp_path, **options)
    plan = reproduce.plan_for(reproduce.ReproduceConfig(**options))
    saved, context = reproduce.read_results(tmp_path)
    assert saved == json.loads(json.dumps(rows)) and context["preset"] == "quick" and context["wall_seconds"] > 0
    assert context["opnet_version"] == opnet.__version__ and len(context["date"]) == len("2026-12-02")
    assert context["plan"] == plan.keys() and {r["entry"] for r in saved} == set(plan.keys())  # each row's entry
    name = {e.key: e.name for e in plan.entries}
    bodies = [e for e in plan.entries if e.part == "bodies"]
    headline = [line.split(" | ")[0].lstrip("| ") for line in headline_markdown(saved)[2:]]  # the README's rows
    networks = [e.name for e in plan.entries if e.runs and e.table == "table1"]
    assert headline == [name[k] for k in ("int+ext", "int", "ext", "ours", "nn", "base-shape")] + [
        e.name
        for e in bodies  # the rows beside Table 1 come after it
    ]
    assert reproduce.results_markdown(saved, context) == (tmp_path / "results.md").read_text()  # all it needs
    t1 = [r for r in saved if r["table"] == "table1"]
    assert {(r["method"], r["split"]) for r in t1} == {
        (m, s) for m in [*networks, name["nn"], name["base-shape"]] for s in evaluate.TEST_SETS
    } | {(e.name, s) for e in plan.entries if e.part == "refine" for s in reproduce.REFINE_SETS}
    for e in bodies:  # our variant on more bodies: its rows say which
        mine = [r for r in t1 if r["entry"] == e.key]
        assert mine and all({k: r[k] for k in ("bodies", "poses", "ensemble") if k in r} == e.fields for r in mine)
        assert all(r["group"] == e.spec.group and r["run"] == "+".join(s.run_name for s in e.runs) for r in mine)
    seeds = sum(len(e.runs) for e in bodies)
    assert seeds > len(bodies)  # an ensemble's seeds: each trained
    matching = ("geometric", "funcchar", "funcchar_int", "sfl")  # the geometric baselines, on a few shapes
    refined = [r for r in t1 if r.get("refined") or r.get("baseline") in matching]
    assert len(refined) == 12 + 2 * len(bodies)
    for key, channels in (("funcchar", reproduce.FUNCCHAR), ("funcchar_int", FUNCCHAR_INT)):
        assert {tuple(r["channels"]) for r in refined if r.get("baseline") == key} == {channels}
    for claim in (
        "funcchar-offset-helps",
        "sfl-best-d_E",
        "operatornet-beats-sfl",
        "sfl-d_E-below-nn",
        "operatornet-beats-funcchar",
        "operatornet-beats-funcchar-int",
    ):
        assert not claims.judge(claim, saved).missing, claim  # its two rows are there
    for r in refined:  # a refinement's rows carry its network's run fields
        start = plan[r["entry"]].refines
        assert start is None or r["run"] == plan[start].run_fields()["run"]
    assert all(r["n_shapes"] == 3 for r in refined)  # at most refine_shapes per test set
    assert all(np.isfinite(r["d_R_before"]) for r in refined if r["method"].endswith("refinement"))
    abl = [r for r in saved if r["table"] == "ablation"]
    assert len(abl) == 28 and {r["split"] for r in abl} == {"test"}
    assert np.isfinite(reproduce.ablation_table(saved)).all()
    for r in saved:
        assert {
            "method",
            "channels",
            "depth",
            "split",
            "d_R",
            "d_V",
            "d_E",
            "n_shapes",
            "train_seconds",
            "preset",
            "device",
            "seconds_per_shape",
        } <= set(r)
    md = (tmp_path / "results.md").read_text()
    assert "OperatorNet (Int+Ext)" in md and "1.11" in md and "Ablation" in md and "8.61" in md
    assert "OperatorNet ours (Int+Ext)" in md and "s/shape" in md and "refinement changes" in md
    assert "FuncChar (Int+Ext)'s d_R / OperatorNet (Int+Ext)'s" in md and "28.4" in md  # beside the paper's
    for name in (
        "training_curves",
        "ablation",
        "reconstructions_test",
        "reconstructions_test_subjects",
        "refinement_curves",
        "refinement_steps",
    ):
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 1000
    # a second call trains nothing more: every run is finished
    mtimes = {p: p.stat().st_mtime for p in (tmp_path / "runs").rglob("latest.pt")}
    named = {run for r in saved for run in (r.get("provenance") or {}).get("runs", [])}
    assert {p.parent.name for p in mtimes} == named and len(named) <= 32 + seeds  # one folder per distinct training
    reproduce.reproduce(
        "quick", tmp_path, budget=budget, device="cpu", progress=False, figures=False, applications=False, maps=False
    )
    assert mtimes == {p: p.stat().st_mtime for p in (tmp_path / "runs").rglob("latest.pt")}
    # a call with fewer parts keeps what the folder already measured: the ablation and the refinement rows stay
    saved = reproduce.read_results(tmp_path)[0]  # the second call's
    again = reproduce.reproduce(
        "quick",
        tmp_path,
        budget=budget,
        device="cpu",
        progress=False,
        figures=False,
        applications=False,
        maps=False,
        ablation=False,
        refine=False,
    )
    merged, context = reproduce.read_results(tmp_path)
    assert merged == json.loads(json.dumps(again)) and len(merged) == len(saved)
    assert {row_identity(r) for r in merged} == {row_identity(r) for r in saved}

    def not_measured_again(r):
        return r["table"] == "ablation" or r.get("refined") or r.get("baseline") in matching

    kept = [r for r in merged if not_measured_again(r)]
    assert kept == [r for r in saved if not_measured_again(r)] and len(kept) == 28 + len(refined)  # as written
    md = (tmp_path / "results.md").read_text()
    assert context["earlier"][0]["tables"] == ["ablation", "table1"] and "earlier call" in md
    assert [r["method"] for r in merged if r["table"] == "table1"][0] == "OperatorNet (Int+Ext)"  # kept in place
    assert "Geometric (A+E): evaluated on 3 of the" in md  # the subset is still told apart from the whole test set


def test_reproduce_applications_on_generated_humans(humans, tmp_path, profile_loads, recorded_figures):
    """The applications' rows of every method and kind, their figures' contents (recorded instead of rendered:
    tests/test_plotting.py renders both kinds of figure), a second call that reuses the trainings and keeps the
    refined rows."""
    profile_loads("humans", humans)
    drawn = recorded_figures("plot_interpolations", "plot_analogies")  # what each figure draws
    budget = reproduce.Budget(
        epochs=1,
        ablation_epochs=1,
        batch_size=64,
        hidden=16,
        refine_steps=2,
        refine_shapes=1,  # Table 1's operator-matching rows (SfL, FuncChar, ...): one shape each, a second or two
        pointnet_epochs=1,
        analogies=5,
        paths=2,
        apps_refine_shapes=4,
    )
    rows = reproduce.reproduce(
        "quick", tmp_path, budget=budget, device="cpu", progress=False, ablation=False, maps=False, points=True
    )  # with the other point-set autoencoders (part "points")
    assert {r["method"] for r in rows if r["table"] == "table1"} >= {"PointNet AE", "PointNet++ AE"}
    (pointnet,) = (tmp_path / "runs").glob("table1-pointnet-*")  # its name and the digest of its budget and data
    assert (pointnet / "best.pt").is_file()
    names = [
        "OperatorNet (mult.)",
        "OperatorNet (linear)",
        "OperatorNet ours (mult.)",
        "OperatorNet (mult.) + refinement",
        "PointNet AE",
        "PointNet AE (transformer)",
        "PointNet++ AE",
        "Nearest neighbour",
    ]
    ana = [r for r in rows if r["table"] == "analogy"]
    kinds = ("pose", "body", "gender")  # the humans' profile names the gender transfer too
    assert [(r["method"], r["kind"]) for r in ana] == [(m, k) for m in names for k in kinds]
    assert all(r["n"] == (4 if "refinement" in r["method"] else 5) and np.isfinite(r["d_R"]) for r in ana)
    itp = [r for r in rows if r["table"] == "interpolation"]
    assert [(r["method"], r["kind"]) for r in itp] == [
        (m, k) for k in ("pose", "body") for m in ["Ground truth", *names]
    ]
    md = (tmp_path / "results.md").read_text()
    assert "## Applications" in md and "PointNet AE / OperatorNet" in md and "smoothness" in md
    for name in ("interpolation_pose", "interpolation_body", "analogy_pose", "analogy_body", "analogy_gender"):
        assert (tmp_path / "figures" / f"{name}.png").is_file()
    assert len(drawn["plot_interpolations"]) == 2 and len(drawn["plot_analogies"]) == 3  # pose, body (, gender)
    for (paths, faces, t), options in drawn["plot_interpolations"]:  # every method on one path, beside the truth
        assert list(paths) == names and options["truth"].shape == (len(t), *humans.vertices.shape[1:])
        assert np.array_equal(faces, humans.faces) and options["camera"] == opnet.plotting.side_view(humans)
        assert all(p.shape == options["truth"].shape for p in paths.values())
    for (A, B, C, results, faces), options in drawn["plot_analogies"]:  # every method on the first three questions
        assert len(A) == len(B) == len(C) == len(options["truth"]) == 3 and list(results) == names
        assert np.array_equal(faces, humans.faces)
        assert all(x.shape == A.shape for x in results.values())
    assert all(np.isfinite(r["d_R_before"]) for r in ana if "refinement" in r["method"])
    latest = pointnet / "latest.pt"
    mtime = latest.stat().st_mtime
    again = reproduce.reproduce(
        "quick",
        tmp_path,
        budget=budget,
        device="cpu",
        progress=False,
        ablation=False,
        figures=False,
        refine=False,
        maps=False,
    )
    assert latest.stat().st_mtime == mtime  # the finished PointNet run is reused, not retrained
    refined = [
        r for r in json.loads(json.dumps(rows)) if r["table"] in ("analogy", "interpolation") and r.get("refined")
    ]
    assert refined and [r for r in again if r.get("refined") and r["table"] != "table1"] == refined  # kept as they were
    assert "analogy" in reproduce.read_results(tmp_path)[1]["earlier"][0]["tables"]  # and said to come from before


def test_reproduce_with_seeds_gives_the_applications_intervals_and_judges_their_claims(
    humans, tmp_path, profile_loads, monkeypatch
):
    """With seeds, every network's analogy and interpolation rows are summarised over its trainings, on the same
    questions and paths, so that the paper's application claims are judged by paired comparisons."""
    from opnet.experiments import claims

    profile_loads("humans", humans)
    budget = reproduce.Budget(
        epochs=1, ablation_epochs=1, batch_size=64, hidden=16, pointnet_epochs=1, analogies=4, paths=2
    )
    options = dict(budget=budget, device="cpu", progress=False, ablation=False, maps=False, bodies=False)
    rows = reproduce.reproduce("quick", tmp_path, seeds=2, refine=False, figures=False, **options)
    apps = [r for r in rows if r["table"] in ("analogy", "interpolation") and r.get("run") is not None]
    networks = {"int+ext", "ours", "pointnet"}  # the applications' trained methods (no --points)
    assert {r["entry"] for r in apps} == networks and all(r["seeds"] == [0, 1] for r in apps)
    for r in apps:  # each row records the trainings its own method decoded with, both seeds of one network
        mine = r["provenance"]["runs"]  # the run folders: each run's name and its digest
        assert len(mine) == len(r["runs"]) == 2 and all(x.startswith(f"{n}-") for x, n in zip(mine, r["runs"]))
    ana = next(r for r in apps if r["table"] == "analogy" and r["method"] == "PointNet AE" and r["kind"] == "pose")
    assert np.shape(ana["d_R_shapes"]) == (2, 4) and ana["d_R_low"] <= ana["d_R"] <= ana["d_R_high"]
    shown = report.value_text(ana, "d_R", 1e4)  # the tables print the interval: mean ± half-width
    assert " ± " in shown and f"| PointNet AE | 4 | {shown} (" in (tmp_path / "results.md").read_text()
    itp = next(r for r in apps if r["table"] == "interpolation" and r["method"] == "OperatorNet (linear)")
    assert np.shape(itp["smoothness_shapes"]) == (2, 2) and itp["smoothness_seeds"] is not None
    nn = [r for r in rows if r["table"] == "analogy" and r.get("baseline") == "nearest_neighbour"]
    assert len(nn) == 3 and "seeds" not in nn[0]  # a baseline is the same in every seed: one row per kind
    assert all(not r["provenance"]["runs"] for r in nn)  # NN decodes with no training
    judged = {j.claim.key: j for j in claims.judge_all(rows, claims.CLAIMS)}
    assert judged["analogy-pose-below-pointnet"].comparison is not None  # measured, with its interval
    smooth = judged["interpolation-body-smoother-than-the linear algebra"]
    body = [r for r in apps if r["table"] == "interpolation" and r["kind"] == "body"]
    assert smooth.comparison is not None or not np.isfinite([r["smoothness_shapes"] for r in body]).all()

    def refuse(*args, **kwargs):
        raise AssertionError("the applications were measured again on the same checkpoints")

    monkeypatch.setattr(reproduce, "seeded_applications_rows", refuse)  # a second call keeps the step's rows
    again = reproduce.reproduce("quick", tmp_path, seeds=2, refine=False, figures=False, **options)

    def apps_of(found):
        return json.dumps([r for r in found if r["table"] in ("analogy", "interpolation")])

    assert apps_of(again) == apps_of(rows)


def test_reproduce_comp_and_discretisation_rows(
    humans, root, tmp_path, profile_loads, tiny_collection, monkeypatch, recorded_figures
):
    """Table 1's Comp networks train on operators through computed maps; test shapes on 2k and 5k meshes are decoded
    by them and by Table 1's, beside the exact 1k operators of the same shapes."""
    few = humans.subset(np.concatenate([humans.indices(s)[::16] for s in opnet.data.SPLITS]))  # 3 test shapes
    profile_loads("humans", few)
    budget = reproduce.Budget(epochs=2, ablation_epochs=1, batch_size=8, hidden=16, discretisation_shapes=2)
    data = tmp_path / "data"
    options = dict(budget=budget, device="cpu", progress=False, ablation=False, applications=False, refine=False)
    rows = reproduce.reproduce("quick", tmp_path, data_root=str(data), **options)
    plan = reproduce.plan_for(reproduce.ReproduceConfig(**options))
    comp = [r for r in rows if r["table"] == "table1" and r.get("group") in MAPPED_GROUPS]
    assert {(r["method"], r["split"]) for r in comp} == {
        (e.name, s) for e in plan.entries if e.part == "maps" for s in evaluate.TEST_SETS
    }
    comp = opnet.data.mapped_collection(few, "2k", root=data)  # cached by reproduce
    for short in ("A+E+C", "Ext"):  # the Comp networks were trained on it
        (folder,) = (tmp_path / "runs").glob(f"comp-{short}-d1-*")
        config = json.loads((folder / "config.json").read_text())
        assert config["data"]["fingerprint"] == train.collection_fingerprint(comp, opnet.CHANNEL_SETS[short])
    spec = plan["comp-half-ext"].spec  # beside them: half the shapes through the maps, half exact
    config = json.loads(
        (spec.run_dir(tmp_path / "runs", opnet.data.half_mapped(few, comp)) / "config.json").read_text()
    )
    half = opnet.data.half_mapped(few, comp)
    assert config["data"]["fingerprint"] == train.collection_fingerprint(half, ("extrinsic",))
    ops = half.operators[half.indices("train")]
    n_comp = len(few.indices("train")[::2])
    assert np.array_equal(ops[:n_comp], comp.operators[few.indices("train")[::2]])
    assert np.array_equal(ops[n_comp:], few.operators[few.indices("train")[1::2]])
    for split in ("val", "test"):  # held out through the maps, like the Comp networks'
        assert np.array_equal(half.operators[half.indices(split)], comp.operators[few.indices(split)])
    assert len(list(data.glob("*computed2k*.json"))) == 1  # the 2k computed rows reuse it: no subset of their own
    disc = [r for r in rows if r["table"] == "discretisation"]
    encodings = [("1k", "exact"), *DISCRETISATIONS]
    decoders = [e for e in plan.entries if e.other_meshes]
    assert [(r["resolution"], r["maps"], r["method"]) for r in disc] == [
        (*enc, e.name) for enc in encodings for e in decoders
    ]
    assert all(r["run"] == plan[r["entry"]].spec.run_name for r in disc)  # each network's rows carry its run
    assert all(r["n_shapes"] == 2 and np.isfinite(r["d_R"]) for r in disc)  # 2 of the 3 test shapes
    errors = {(r["resolution"], r["maps"]): r["map_error"] for r in disc}
    assert 0 < errors["2k", "computed"] < 0.05 and 0 < errors["5k", "computed"] < 0.05  # metres
    md = (tmp_path / "results.md").read_text()
    assert "Other triangulations" in md and "| OperatorNet (Comp)(Int+Ext) |" in md
    t1 = {r["method"]: r["d_R"] for r in rows if r["table"] == "table1" and r["split"] == "test"}
    ratio = t1["OperatorNet (Comp)(Ext)"] / t1["OperatorNet (Int+Ext)"]
    assert f"OperatorNet (Comp)(Ext)'s d_R / OperatorNet (Int+Ext)'s (ground-truth maps) = {ratio:.3g} (" in md
    get = {(r["resolution"], r["maps"], r["method"]): r["d_R"] for r in disc}
    ratio = get["5k", "computed", "OperatorNet (Ext)"] / get["1k", "exact", "OperatorNet (Int+Ext)"]
    assert f"- OperatorNet (Ext): {1e4 * get['5k', 'computed', 'OperatorNet (Ext)']:.3g}, {ratio:.1f}×" in md
    for name in ("discretisation", "generalisation"):
        assert (tmp_path / "figures" / f"{name}.png").stat().st_size > 1000
    # the paper's appendix: a network trained with 2k-vertex labels from the 1k operators, measured on the 2k shapes
    labels = opnet.data.labels_collection(few, "2k", root=data)
    entry = plan["labels-2k"]
    (folder,) = (tmp_path / "runs").glob("labels-2k-A+E+C-d1-*")
    config = json.loads((folder / "config.json").read_text())
    assert config["data"]["fingerprint"] == train.collection_fingerprint(labels, opnet.KINDS)
    idx = reproduce.discretisation_indices(few, budget)
    net = train.load_model(folder / "best.pt", device="cpu")
    sub = labels.subset(idx)
    (exact,) = evaluate.evaluate(sub, [evaluate.operatornet_method(net, sub, "x")], ("test",))
    (row,) = [r for r in disc if r["entry"] == "labels-2k" and r["resolution"] == "1k"]
    assert row["d_R"] == pytest.approx(exact["d_R"]) and row["labels"] == "2k" and row["method"] == entry.name
    # a network of several seeds decodes with each: one row per encoding over them, each seed's mean as alone
    from opnet.experiments.runner import train_run

    spec = dataclasses.replace(plan["int+ext"].spec, seeds=(0, 1))
    runs = [train_run(s, few, tmp_path / "runs", device="cpu") for s in spec.replicates()]
    both = reproduce.discretisation_rows(few, {"two": runs}, budget, comp=comp, data_root=str(data))
    alone = reproduce.discretisation_rows(few, {"one": runs[1].net}, budget, comp=comp, data_root=str(data))
    assert [(r["resolution"], r["maps"]) for r in both] == encodings
    for r, one in zip(both, alone):
        assert r["seeds"] == [0, 1] and np.shape(r["d_R_shapes"]) == (2, 2) and r["d_R_low"] < r["d_R_high"]
        assert r["d_R_seeds"][1] == pytest.approx(one["d_R"]) and r["runs"] == [s.run_name for s in spec.replicates()]
    # FuncChar's geometric reconstruction of the 5k inputs (the paper's appendix), its channels through their own maps
    fields = {"one": dict(entry="int+ext", **plan["int+ext"].run_fields())}
    few_steps = dataclasses.replace(budget, refine_steps=3)
    figure = recorded_figures("plot_mapped_reconstructions")["plot_mapped_reconstructions"]
    # the figure's maps, computed again for it, are not drawn; the rows' maps are in the data root already (a map
    # computed here would fail on this None)
    monkeypatch.setattr("opnet.matching.compute_map", lambda *args, **kwargs: None)
    with_fc = reproduce.discretisation_rows(
        few, {"one": runs[0].net}, few_steps, fields=fields, comp=comp, data_root=str(data), funcchar=True,
        out=tmp_path / "fc",
    )  # fmt: skip
    (((_, drawn, truth), _),) = figure  # one figure: its maps, reconstructions (name -> shapes) and true shapes
    drawn = dict(drawn, truth=truth)
    assert set(drawn) == {"one", "FuncChar (Int+Ext)", "truth"}  # FuncChar's reconstruction beside the network's
    assert drawn["FuncChar (Int+Ext)"].shape == drawn["truth"].shape and np.isfinite(drawn["FuncChar (Int+Ext)"]).all()
    assert not np.allclose(drawn["FuncChar (Int+Ext)"], drawn["one"])
    (fc,) = [r for r in with_fc if r.get("baseline") == "funcchar"]
    assert (fc["resolution"], fc["maps"], fc["method"], fc["table"]) == (
        "5k",
        "computed",
        "FuncChar (Int+Ext)",
        "discretisation",
    )
    assert fc["n_shapes"] == 2 and np.isfinite(fc["d_R"]) and fc["channels"] == list(reproduce.FUNCCHAR)
    assert 0 < fc["map_error"] < 0.05 and fc["map_error"] == pytest.approx(errors["5k", "computed"], rel=0.5)
    assert not claims.judge("5k-funcchar-behind", with_fc).missing  # the claim finds its two rows
    # the figure's shapes are its row's, in its order: each drawn reconstruction's d_R is the row's for that shape
    assert fc["shapes"] == [0, 1]  # the two shapes mapped, both drawn (the three farthest, or as many as there are)
    drawn_d_R = opnet.d_R(drawn["truth"], drawn["FuncChar (Int+Ext)"])
    np.testing.assert_allclose(drawn_d_R, fc["d_R_shapes"], rtol=1e-6)
    with pytest.raises(ValueError, match="generated 1k humans|not made by a generator"):
        opnet.data.mapped_collection(tiny_collection("humans"), "2k")
    with pytest.raises(ValueError, match="shapes must be"):
        reproduce.discretisation_figure(comp, {"net": None}, shapes=0)
    with pytest.raises(ValueError, match="maps='computed'"):
        reproduce.discretisation_figure(few, {"net": None})
    with pytest.raises(ValueError, match="from its shapes' 2k meshes through computed maps"):
        evaluate.sfl_method(comp)  # SfL reads the full Laplacian in known correspondence


def test_unseen_species_are_the_whole_species_held_out_and_only_species_collections_have_them(coll):
    """``unseen_species``: the ``test_subjects`` shapes whose body is a species of ``meta["species"]`` (not a blend);
    a collection without species names the sets it has."""
    import dataclasses

    held = coll.indices("test_subjects")
    subjects = coll.subject.astype("<U20")  # room for the names below
    subjects[held[::2]] = "wolf"  # half the held-out bodies are a whole species, the rest blends with it
    subjects[held[1::2]] = "wolf50+fox50"
    subjects[coll.indices("train")[:3]] = "fox"  # a seen species: never in the set
    animals = dataclasses.replace(coll, subject=subjects, meta=dict(coll.meta, species=["fox", "wolf"]))
    np.testing.assert_array_equal(evaluate.test_set_indices(animals, "unseen_species"), held[::2])
    rows = evaluate.evaluate(animals, [evaluate.base_shape_method(animals)], ("test_subjects", "unseen_species"))
    assert [(r["split"], r["n_shapes"]) for r in rows] == [
        ("test_subjects", len(held)),
        ("unseen_species", len(held[::2])),
    ]
    with pytest.raises(ValueError, match="several species.*eval_subset"):
        evaluate.test_set_indices(coll, "unseen_species")


def test_ensemble_is_invariant_to_each_members_placement(coll):
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec([0.3, -1.0, 0.4]).as_matrix()
    truth = evaluate.Method("truth", lambda idx: coll.vertices[idx].astype(np.float64))
    moved = evaluate.Method("moved", lambda idx: coll.vertices[idx].astype(np.float64) @ R.T + [1.0, 2.0, 3.0])
    shrunk = evaluate.Method("shrunk", lambda idx: 0.8 * coll.vertices[idx].astype(np.float64))
    idx = np.arange(5)
    np.testing.assert_allclose(
        evaluate.ensemble_method([truth, moved]).reconstruct(idx), truth.reconstruct(idx), atol=1e-5
    )
    mean = evaluate.ensemble_method([truth, shrunk], name="mean")  # the average of what they say, once aligned
    assert mean.name == "mean"
    np.testing.assert_allclose(
        mean.reconstruct(idx), opnet.metrics.rigid_align(0.9 * coll.vertices[idx], coll.vertices[idx]), atol=1e-4
    )
    with pytest.raises(ValueError, match="two or more"):
        evaluate.ensemble_method([truth])


def test_an_ensemble_is_evaluated_on_the_fewest_shapes_its_members_allow(coll):
    fast = evaluate.Method("fast", lambda idx: coll.vertices[idx].astype(np.float64))
    slow = evaluate.Method("slow", lambda idx: coll.vertices[idx].astype(np.float64), max_shapes=3)
    assert evaluate.ensemble_method([fast, slow]).max_shapes == 3
    assert evaluate.ensemble_method([fast, fast]).max_shapes is None
