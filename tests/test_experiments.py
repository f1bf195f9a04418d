"""The experiment layer: the plan's entries and their selection, the targets as records, the rows' fields, baselines
and collection profiles registered by a test, a channel of one's own in the reproduction's ablation, and the configs
that generate the commands' options."""

import dataclasses
import json
import shutil
import sys

import numpy as np
import pytest

import opnet
from opnet import reproduce
from opnet.__main__ import _parser, main
from opnet.experiments import baselines, config, plan, report, targets

BUDGET = plan.Budget(epochs=2, ablation_epochs=1, batch_size=8, hidden=16, refine_steps=3, refine_shapes=3)

HALF_AREA_SOURCE = '''
import opnet


class HalfArea(opnet.inner_products.AreaInnerProduct):
    """Half the area inner product: another channel, of one's own."""

    name = "half area"

    def project(self, vertices, faces, evecs):
        return 0.5 * super().project(vertices, faces, evecs)

    def project_batch(self, vertices, faces, evecs):
        return 0.5 * super().project_batch(vertices, faces, evecs)
'''


@pytest.fixture
def half_area(tmp_path, monkeypatch):
    """``"half_area_ip:HalfArea"``, importable for this test."""
    (tmp_path / "half_area_ip.py").write_text(HALF_AREA_SOURCE)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield "half_area_ip:HalfArea"
    sys.modules.pop("half_area_ip", None)


@pytest.fixture
def capsules(monkeypatch, tiny_collection):
    """A collection of the test's own, registered as the profile ``capsules`` (no generator: no applications)."""
    coll = tiny_collection("capsules")
    p = opnet.data.Profile("capsules", load=lambda preset, root=None, progress=None, **draws: coll)
    monkeypatch.setitem(opnet.data.PROFILES, "capsules", p)
    return coll


# -- the plan ------------------------------------------------------------------------------------------------------


def test_every_entry_is_declared_once_with_a_stable_key():
    declared = plan.declare(BUDGET)
    keys = declared.keys()
    assert len(keys) == len(set(keys)) and len(declared) == len(keys) + len(declared.steps)
    assert {"int+ext", "int", "ext", "ours", "pointnet", "nn", "base-shape", "geometric", "funcchar"} <= set(keys)
    assert plan.declare(BUDGET).keys() == keys  # the same plan twice
    for e in declared.entries:
        if e.refines is not None:  # a refinement follows what it refines
            assert keys.index(e.refines) < keys.index(e.key)
    # the paper's rows are declared by the entries that stand beside them: one name each
    assert set(plan.PAPER_ROWS) == set(opnet.experiments.PAPER_TABLE1)
    assert report.PAPER_TABLE1_ROWS is plan.PAPER_ROWS


def test_the_presets_are_listed_once_each_with_its_budget():
    pytest.importorskip("torch")  # the command line's parser reads TrainConfig (the net extra)
    assert plan.PRESETS == tuple(opnet.data.generators.PRESETS) and set(plan.BUDGETS) == set(plan.PRESETS)
    assert _parser().parse_args(["train", "--run-dir", "r", "--preset", "paper"]).preset == "paper"
    with pytest.raises(SystemExit):
        _parser().parse_args(["reproduce", "--preset", "huge"])


def test_selecting_parts_keeps_their_entries_and_drops_orphan_refinements():
    declared = plan.declare(BUDGET)
    only = plan.select(declared, ())
    assert {e.part for e in only.entries} == {"table1"} and not only.steps
    refine = plan.select(declared, ("refine",))  # the refinements of the bodies' networks need the bodies part
    assert "bodies-shape+refined" not in refine and "int+ext+refined" in refine
    assert "bodies-shape+refined" in plan.select(declared, ("refine", "bodies"))
    with pytest.raises(ValueError, match="unknown parts"):
        plan.select(declared, ("tables",))
    with pytest.raises(KeyError, match="no entry 'nope'"):
        declared["nope"]


def test_an_entry_is_a_network_a_baseline_or_a_refinement():
    spec = plan.spec("table1", BUDGET)
    with pytest.raises(ValueError, match="exactly one of"):
        plan.Entry("both", "both", spec, baseline="nearest_neighbour")
    with pytest.raises(ValueError, match="exactly one of"):
        plan.Entry("none", "none")
    with pytest.raises(ValueError, match="part must be one of"):
        plan.Entry("x", "x", spec, part="tables")
    with pytest.raises(ValueError, match="trained_on must be one of"):
        plan.Entry("x", "x", spec, trained_on="5k")
    assert plan.Entry("x", "x", spec, trained_on="half").tested_on == "comp"  # tested like the Comp networks
    ensemble = plan.declare(BUDGET)["bodies-shape-poses-quarter"]
    assert ensemble.run_fields()["run"] == "+".join(s.run_name for s in ensemble.runs) and len(ensemble.runs) == 2


def test_the_config_decides_the_parts_from_the_profile():
    humans = config.ReproduceConfig()
    assert humans.parts() == tuple(p for p in plan.PARTS if p != "points")  # every part applies to the humans ...
    assert config.ReproduceConfig(points=True).parts() == plan.PARTS  # ... the costly point-set autoencoders if asked
    animals = config.ReproduceConfig(collection="animals")
    assert "maps" not in animals.parts() and "bodies" not in animals.parts() and "applications" in animals.parts()
    assert "ablation" not in config.ReproduceConfig(ablation=False).parts()
    with pytest.raises(ValueError, match="--no-maps"):
        config.ReproduceConfig(collection="animals", maps=True)
    with pytest.raises(ValueError, match="unknown preset"):
        config.ReproduceConfig(preset="huge")
    with pytest.raises(ValueError, match="unknown collection 'cats'"):
        config.ReproduceConfig(collection="cats")
    with pytest.raises(TypeError, match="sequence of channel sets"):
        config.ReproduceConfig(ablation_channels="area,extrinsic")
    with pytest.raises(ValueError, match="the module 'nowhere_pkg' does not import"):  # refused before any training
        config.ReproduceConfig(ablation_channels=("area,nowhere_pkg:MyIP",))
    with pytest.raises(ValueError, match="reproducible=False"):
        config.ReproduceConfig(collection="heads")
    for jobs in (0, True, 1.5):
        with pytest.raises(ValueError, match="jobs must be a count of processes"):
            config.ReproduceConfig(jobs=jobs)


def test_the_commands_options_are_the_configs_fields():
    pytest.importorskip("torch")  # the command line's parser reads TrainConfig (the net extra)
    args = _parser().parse_args(
        ["reproduce", "--no-maps", "--ablation-channels", "area,offset_area", "--ablation-channels", "Ext"]
    )
    made = opnet.options.config_from_args(config.ReproduceConfig, args)
    assert made.maps is False and made.bodies is None and made.ablation_channels == ("area,offset_area", "Ext")
    every = {f.name for f in dataclasses.fields(config.ReproduceConfig) if f.metadata["cli"]}
    assert every <= set(vars(args))  # each field with a flag is an option
    assert (
        opnet.options.config_from_args(config.ReproduceConfig, _parser().parse_args(["reproduce"]))
        == config.ReproduceConfig()
    )
    evaluate = _parser().parse_args(["evaluate", "--run-dir", "r"])
    assert opnet.options.config_from_args(config.EvaluateConfig, evaluate).run_dir == "r"
    with pytest.raises(SystemExit):  # --run-dir is required
        _parser().parse_args(["evaluate"])


# -- targets -------------------------------------------------------------------------------------------------------


def _row(split="test", d_R=1e-4, **fields):
    return dict(table="table1", split=split, d_R=d_R, d_V=0.01, d_E=0.04, method="m", **fields)


def test_targets_are_judged_on_rows_by_their_fields():
    paper, nn = plan.PAPER_ROWS["OperatorNet (Int+Ext)"], plan.PAPER_ROWS["Nearest neighbour (Int+Ext)"]
    rows = [_row(d_R=1e-4, **paper), _row(d_R=12e-4, **nn), _row(d_R=0.5e-4, **dict(paper, variant="ours"))]
    by_key = {t.key: t for t in targets.TARGETS}
    (v,) = targets.judge(by_key["nn-ratio-test"], rows)
    assert v.value == pytest.approx(12) and v.met and v.target.threshold == 10 and v.target.at_least
    (v,) = targets.judge(by_key["ours-gain"], rows)
    assert v.value == pytest.approx(2) and v.met
    (v,) = targets.judge(by_key["d_V"], rows)
    assert v.value == 0.01 and v.met and v.denominator is None
    rows[1]["d_R"] = 8e-4  # NN closer: the target is missed
    assert not targets.judge(by_key["nn-ratio-test"], rows)[0].met
    assert targets.judge(by_key["nn-ratio-test_subjects"], rows) == []  # no rows on that split: no verdict
    lines = report.targets(rows)
    assert any("NN's d_R / OperatorNet (Int+Ext)'s = 8 (" in line and "missed" in line for line in lines)
    assert not any("target" in line for line in report.targets(rows, paper=False))


def test_refinement_is_set_beside_the_seed_it_refined():
    """A seeded row (one run per seed) and the refinement of its seed 0: the Targets line finds the refinement by the
    seeds' runs and says which seed it refined."""
    paper = plan.PAPER_ROWS["OperatorNet (Int+Ext)"]
    runs = ["net", "net-s1", "net-s2"]
    rows = [
        _row(d_R=1e-4, run="+".join(runs), runs=runs, seeds=[0, 1, 2], **paper),
        _row(d_R=0.5e-4, d_R_before=0.8e-4, run="net", seeds=[0], refined=True, n_shapes=80),
    ]
    (line,) = [line for line in report.targets(rows) if "refinement" in line]
    assert "seed 0's m's d_R by -38 % (0.8 → 0.5 ×10⁻⁴ on the same 80 shapes)" in line
    rows[1]["run"] = "other"  # another network's refinement is not set beside this one
    assert not [line for line in report.targets(rows) if "refinement" in line]
    one = [
        _row(d_R=1e-4, run="net", **paper),
        _row(d_R=0.5e-4, d_R_before=0.8e-4, run="net", refined=True, n_shapes=80),
    ]
    (line,) = [line for line in report.targets(one) if "refinement" in line]  # a one-seed row: no seed named
    assert "changes m's d_R by -38 %" in line
    one[1]["d_R"] = None  # a refinement without its measurement is left out, not an error
    assert not [line for line in report.targets(one) if "refinement" in line]


def test_the_discretisation_figure_draws_the_farthest_shape_of_each_of_the_farthest_motions():
    from opnet.experiments.figures import most_deformed

    far = np.array([1.0, 5.0, 3.0, 4.0, 2.0, 2.0])  # distances from the base
    motions = np.array(["a", "b", "c", "b", "a", "d"])
    assert most_deformed(far, motions, 2).tolist() == [1, 2]  # b's farthest (5), then c's (3): not b's 4
    assert most_deformed(far, motions, 4).tolist() == [1, 2, 4, 5]  # a's and d's tie at 2: both, a's lower index
    assert most_deformed(far, motions, 5).tolist() == [1, 2, 3, 4, 5]  # four motions, then the farthest left
    assert most_deformed(far, np.array(["a"] * 6), 2).tolist() == [1, 3]  # one motion: the farthest shapes
    assert most_deformed([2.0, 2.0], ["a", "a"], 1).tolist() == [0]  # of equal distances, the lower index
    assert most_deformed(far, motions, 9).tolist() == list(range(6))  # all there are
    for bad in (dict(shapes=0), dict(distances=[np.nan] * 6), dict(motions=motions[:5])):
        with pytest.raises(ValueError):
            most_deformed(**(dict(distances=far, motions=motions, shapes=2) | bad))


def test_every_target_names_its_rows_threshold_and_source():
    for t in targets.TARGETS:
        assert t.numerator and t.source and t.threshold > 0 and t.table in ("table1", "discretisation", "analogy")
    assert len({t.key for t in targets.TARGETS}) == len(targets.TARGETS)


# -- the ablation of any set ---------------------------------------------------------------------------------------


def test_a_set_of_ones_own_joins_the_plan_once():
    made = config.ReproduceConfig(ablation_channels=("area,offset_area", "extrinsic,area"), collection="animals")
    labels = {e.name for e in reproduce.plan_for(made).entries if e.table == "ablation"}
    assert "OperatorNet (Area+offset_area) depth 1" in labels  # beside the paper's seven
    assert len(labels) == 8 * len(plan.ABLATION_DEPTHS)  # "extrinsic,area" is the paper's A+E column


def test_the_report_lays_out_a_set_outside_the_papers_grid():
    rows = [
        dict(table="ablation", split="test", depth=d, channels=list(ch), d_R=(i + d) * 1e-4, method="m")
        for d in plan.ABLATION_DEPTHS
        for i, ch in enumerate([*plan.ABLATION_SETS.values(), ("area", "half area")])
    ]
    columns = report.ablation_columns(rows)
    assert columns == [*plan.ABLATION_SETS, "Area+half area"]
    table = report.ablation_table(rows)
    assert table.shape == (4, 8) and np.isfinite(table).all()
    assert table[0, -1] == pytest.approx(1e4 * rows[7]["d_R"])
    md = "\n".join(report.ablation_markdown(rows, dict(epochs=1, ablation_epochs=1)))
    assert "Area+half area" in md and "| – |" in md  # the paper has no number for it
    assert "All three operators give the best column" in md  # A+E+C found by name, not by position


def test_the_ablation_table_prints_a_seeded_cells_interval_and_one_trainings_value_alone():
    one = dict(table="ablation", split="test", depth=1, channels=["area"], d_R=3e-4, method="m")
    seeded = dict(
        one, channels=["area", "extrinsic", "conformal"], d_R=2e-4, d_R_low=1.5e-4, d_R_high=2.5e-4, seeds=[0, 1, 2]
    )
    md = report.ablation_markdown([one, seeded], dict(epochs=60, ablation_epochs=1))
    row = next(line for line in md if line.startswith("| Conv. 8 |"))
    assert "**2** ± 0.5" in row and "| 3 |" in row  # the best cell in bold, its half-width beside it
    assert md[0].startswith("Each network trained 1 epoch (") and "half-width of the 95 % interval" in md[0]
    plain = report.ablation_markdown([one], dict(epochs=60, ablation_epochs=60))
    assert plain[0] == "Each network trained 60 epochs (Table 1's have 60)."


# -- registered by a test: a baseline, a collection, a channel in the ablation -------------------------------------


def test_a_baseline_registered_by_a_test_builds_rows_with_its_key(monkeypatch, tiny_collection):
    pytest.importorskip("torch")  # the runner fingerprints the collection with opnet.train
    coll = tiny_collection()

    def mean_shape(collection, budget, device):
        mean = collection.vertices[collection.indices("train")].mean(0).astype(np.float64)
        return opnet.evaluate.Method("Mean shape", lambda idx: np.broadcast_to(mean, (len(idx), *mean.shape)))

    monkeypatch.setitem(baselines.BASELINES, "mean_shape", mean_shape)
    with pytest.raises(ValueError, match="registered already"):
        baselines.register_baseline("mean_shape", mean_shape)
    with pytest.raises(ValueError, match="unknown baseline 'nope'"):
        baselines.baseline_method("nope", coll, BUDGET)
    entry = plan.Entry("mean", "Mean shape", baseline="mean_shape")
    ws = opnet.experiments.runner.Workspace(coll, opnet.data.profile_of("tiny"), "unused", BUDGET)
    rows, done = opnet.experiments.runner.run_entries([entry], ws, extra=dict(preset="tiny"))
    assert {r["split"] for r in rows} == set(opnet.evaluate.TEST_SETS)
    assert all(r["baseline"] == "mean_shape" and r["entry"] == "mean" and r["table"] == "table1" for r in rows)
    assert all(r["epochs"] is None and r["preset"] == "tiny" for r in rows)
    assert done["mean"].method.info["baseline"] == "mean_shape"


@pytest.mark.slow
def test_a_collection_registered_by_a_test_runs_through_reproduce_collection(capsules, tmp_path, monkeypatch):
    """A new collection is one profile: ``python -m opnet reproduce --collection capsules`` runs its plan."""
    monkeypatch.setitem(plan.BUDGETS, "quick", BUDGET)
    out = tmp_path / "out"
    argv = ["reproduce", "--collection", "capsules", "--out", str(out), "--no-ablation", "--no-figures"]
    assert main([*argv, "--device", "cpu"]) == 0
    rows, context = reproduce.read_results(out)
    assert context["data"] == "capsules" and "applications" not in context["plan"]
    assert {r["table"] for r in rows} == {"table1"}  # no generator: no applications, no maps, no bodies
    keys = {r["entry"] for r in rows}
    assert {"int+ext", "int", "ext", "ours", "nn", "base-shape", "geometric", "int+ext+refined"} <= keys
    assert not {"pointnet", "comp-ext", "bodies-shape"} & keys
    md = (out / "results.md").read_text()
    assert "paper d_R" not in md and "DFAUST" not in md  # its profile has no paper numbers
    with pytest.raises(ValueError, match="--no-maps"):
        reproduce.reproduce("quick", out, collection="capsules", maps=True)


@pytest.mark.slow
def test_a_channel_of_ones_own_joins_the_reproductions_ablation(capsules, half_area, tmp_path, monkeypatch):
    monkeypatch.setitem(plan.BUDGETS, "quick", BUDGET)
    out = tmp_path / "out"
    argv = ["reproduce", "--collection", "capsules", "--out", str(out), "--no-refine", "--device", "cpu"]
    assert main([*argv, "--ablation-channels", f"area,{half_area}"]) == 0
    rows, context = reproduce.read_results(out)
    abl = [r for r in rows if r["table"] == "ablation"]
    own = [r for r in abl if r["channels"] == ["area", "half area"]]
    assert len(own) == len(plan.ABLATION_DEPTHS) and len(abl) == 8 * len(plan.ABLATION_DEPTHS)
    assert report.ablation_columns(rows)[-1] == "Area+half area"
    assert np.isfinite(report.ablation_table(rows)).all()
    assert "Area+half area" in (out / "results.md").read_text()
    assert (out / "figures" / "ablation.png").stat().st_size > 1000
    runs = json.loads((out / "runs" / own[0]["provenance"]["runs"][0] / "config.json").read_text())
    assert runs["channel_specs"]["half area"] == half_area  # its class, recorded for `opnet evaluate`


# -- claims --------------------------------------------------------------------------------------------------------


def test_a_claim_is_confirmed_refuted_or_inconclusive_by_its_interval():
    from opnet.experiments import claims

    claim = next(c for c in claims.CLAIMS if c.key == "int+ext-below-ext")
    rng = np.random.default_rng(0)
    hard = rng.gamma(2.0, 1e-4, (3, 40))  # the shapes' own difficulty, shared

    def rows(shift):
        a = dict(table="table1", split="test", method="a", shapes=list(range(40)), **claim.better)
        b = dict(table="table1", split="test", method="b", shapes=list(range(40)), **claim.worse)
        a |= dict(d_R=float((hard - shift).mean()), d_R_shapes=(hard - shift).tolist())
        b |= dict(d_R=float(hard.mean()), d_R_shapes=hard.tolist())
        return [a, b]

    assert claims.judge(claim, rows(1e-5)).verdict == "confirmed"
    assert claims.judge(claim, rows(-1e-5)).verdict == "refuted"
    assert claims.judge(claim, rows(0.0)).verdict == "inconclusive"
    means_only = [{k: v for k, v in r.items() if k != "d_R_shapes"} for r in rows(1e-5)]
    judged = claims.judge(claim, means_only)  # one training, no per-shape errors: no interval, no verdict
    assert judged.verdict == "inconclusive" and judged.comparison is None and judged.better_mean < judged.worse_mean
    assert claims.judge(claim, rows(1e-5)[:1]).missing  # its rows are not all there: not judged
    line = next(x for x in claims.claims_markdown(rows(1e-5)) if claim.statement in x)
    assert "(3 seeds × 40 shapes)" in line and "**confirmed**" in line  # what the difference was paired on
    hard = hard[:1]  # one training of each
    line = next(x for x in claims.claims_markdown(rows(1e-5)) if claim.statement in x)
    assert "(1 seed, 40 shapes)" in line


def test_the_shipped_report_opens_with_the_claims_table():
    from opnet.experiments import claims, shipped

    rows, context = shipped.shipped_results("default")
    sections = report.results_sections(rows, context)
    assert list(sections)[:2] == ["context", "claims"]
    judged = claims.judge_all(rows)
    assert {j.claim.key for j in judged} >= {"int+ext-below-ext", "nn-far-behind", "depth-1-below-2"}
    text = "\n".join(sections["claims"])
    if any(r.get("d_R_shapes") for r in rows):  # a reproduction with per-shape errors: its claims are judged
        assert any(j.verdict != "inconclusive" for j in judged) and "seeds ×" in text
    else:  # one training per number: no interval, so no verdict; the means are shown, those against us too
        assert all(j.verdict == "inconclusive" for j in judged)
        assert "(means: not)" in text and "(means: holds)" in text
    assert len({c.key for c in claims.CLAIMS}) == len(claims.CLAIMS)


@pytest.mark.slow
def test_reproduce_with_seeds_gives_intervals_and_judges_the_claims(capsules, tmp_path, monkeypatch):
    """``reproduce --seeds 2``: each network a run per seed, its rows over both with an interval, and the claims
    judged by paired comparisons instead of left inconclusive."""
    from opnet.experiments import claims

    monkeypatch.setitem(plan.BUDGETS, "quick", BUDGET)
    out = tmp_path / "out"
    argv = ["reproduce", "--collection", "capsules", "--out", str(out), "--no-refine", "--no-figures", "--seeds", "2"]
    assert main([*argv, "--device", "cpu", "--no-ablation"]) == 0
    rows, context = reproduce.read_results(out)
    nets = [r for r in rows if r["table"] == "table1" and r.get("architecture") == "operatornet"]
    assert nets and all(r["seeds"] == [0, 1] and r["d_R_low"] <= r["d_R"] <= r["d_R_high"] for r in nets)
    assert all(len(r["runs"]) == 2 and (out / "runs" / r["provenance"]["runs"][1]).is_dir() for r in nets)
    first = next(r for r in nets if r["entry"] == "int+ext")
    assert first["run"] == "+".join(first["runs"]) and np.shape(first["d_R_shapes"]) == (2, first["n_shapes"])
    assert " ± " in (out / "results.md").read_text()
    judged = {j.claim.key: j for j in claims.judge_all(rows, claims.CLAIMS)}
    assert judged["int+ext-below-ext"].comparison is not None  # measured, with its interval
    assert judged["nn-far-behind"].verdict in claims.VERDICTS


def test_seeds_replicate_the_networks_only_when_asked():
    one, three = plan.declare(BUDGET), plan.declare(BUDGET, seeds=3)
    assert one.keys() == three.keys()  # the same entries, the same keys
    assert not any(e.replicated for e in one.entries)
    replicated = {e.key for e in three.entries if e.replicated}
    assert {"int+ext", "ext", "pointnet", "comp-ext", "ablation-A+E+C-d1"} <= replicated
    assert (
        not {"bodies-shape-poses-quarter", "nn"} & replicated
    )  # an ensemble keeps its members; baselines train nothing
    assert three["int+ext"].spec.seeds == (0, 1, 2) and len(three["bodies-shape-poses-quarter"].runs) == 2


def test_results_of_other_seeds_are_not_merged_but_those_of_before_seeds_are():
    context = dict(preset="quick", budget={}, splits={}, collection="c")
    old = ([dict(table="table1", method="m", run="r", split="test")], dict(context))  # no "seeds": one each
    assert report.merge_results(old, [], dict(context, seeds=1))[0] == old[0]
    with pytest.warns(UserWarning, match="replaced, not merged"):
        assert report.merge_results(old, [], dict(context, seeds=3))[0] == []


@pytest.mark.slow
def test_reproduce_records_provenance_keeps_current_rows_and_measures_stale_ones_again(capsules, tmp_path, monkeypatch):
    """Every row says which trainings it measured; a second call keeps the rows of the same checkpoints without
    evaluating anything, and a row whose recorded checkpoint is not its run's current one is measured again."""
    from opnet.experiments import provenance, runner

    monkeypatch.setitem(plan.BUDGETS, "quick", BUDGET)
    out = tmp_path / "out"
    options = dict(collection="capsules", ablation=False, figures=False, device="cpu", progress=False)
    first = reproduce.reproduce("quick", out, **options)
    checkpoints = provenance.run_checkpoints(out / "runs")
    for r in first:
        p = r["provenance"]
        assert {"runs", "checkpoints", "seeds", "commit", "date", "machine", "preset", "inputs"} <= set(p)
        assert p["preset"] == "quick" and provenance.current(r, checkpoints)
        if r.get("baseline") is None:  # a network's row: its runs' folders, each checkpoint's SHA-256
            assert p["runs"] and all(checkpoints[run] == sha for run, sha in zip(p["runs"], p["checkpoints"]))
    nets = [r for r in first if r["entry"] == "int+ext"]
    assert nets[0]["provenance"]["runs"][0].startswith(nets[0]["run"] + "-") and "convergence" in nets[0]

    def refuse(*args, **kwargs):
        raise AssertionError("a row of the same checkpoints, data and budget was evaluated again")

    with monkeypatch.context() as m:  # nothing changed: every row is kept, nothing is evaluated
        m.setattr(runner, "evaluate", refuse)
        m.setattr(runner, "evaluate_seeds", refuse)
        again = reproduce.reproduce("quick", out, **options)
    assert again == first

    # a row that records another training of its run than the folder's: dropped, then measured again
    data = json.loads((out / "results.json").read_text())
    stale = next(r for r in data["rows"] if r["entry"] == "ext")
    stale["provenance"]["checkpoints"] = ["0" * 64]
    (out / "results.json").write_text(json.dumps(data))
    evaluated = []
    real = runner.evaluate
    monkeypatch.setattr(
        runner,
        "evaluate",
        lambda coll, methods, *a, **k: evaluated.append(methods[0].name) or real(coll, methods, *a, **k),
    )
    with pytest.warns(UserWarning, match="not their runs' current ones"):
        third = reproduce.reproduce("quick", out, **options)
    assert set(evaluated) == {"OperatorNet (Ext)"}
    by = {(r["entry"], r["split"]): r["d_R"] for r in first}
    assert {(r["entry"], r["split"]): r["d_R"] for r in third} == by  # the same checkpoint measures the same


def test_a_row_is_superseded_by_another_checkpoint_of_its_run_not_by_its_runs_absence():
    from opnet.experiments import provenance

    row = dict(provenance=dict(runs=["a", "b"], checkpoints=["1" * 64, "2" * 64]))
    assert not provenance.superseded(row, {})  # its trainings are elsewhere: it stands
    assert not provenance.superseded(row, {"a": "1" * 64, "c": "3" * 64})
    assert provenance.superseded(row, {"b": "0" * 64})  # another training of one of its runs
    assert provenance.superseded(dict(d_R=1.0), {})  # no provenance: it cannot say
    assert not provenance.current(row, {"a": "1" * 64})  # current: every run here, with its checkpoint
    renamed = {"a": "1" * 64, "b-0123456789": "2" * 64}  # run "b" of the row was "b-<its digest>"
    row_ids = dict(provenance=dict(runs=["a", "b-9876543210"], checkpoints=["1" * 64, "2" * 64]))
    assert not provenance.superseded(row_ids, renamed)
    assert provenance.superseded(row_ids, renamed, by_name=True)  # the same network under another id: other data
    other = dict(provenance=dict(runs=["c"], checkpoints=["3" * 64]))
    assert provenance.measured_checkpoints([row, other, dict(d_R=1.0)]) == {"a": "1" * 64, "b": "2" * 64, "c": "3" * 64}
    with pytest.raises(ValueError, match="no shipped reproduction of the humans at preset 'quick'"):
        config.ReproduceConfig(preset="quick", from_shipped=True)


@pytest.mark.slow
def test_rows_whose_trainings_are_elsewhere_stand_until_a_call_trains_their_runs_to_another_checkpoint(
    capsules, tmp_path, monkeypatch
):
    """A call that starts from a results file whose runs this machine lacks (--from-shipped) keeps the rows of the
    parts it leaves out; a kept row is dropped when it records another checkpoint of a run than the folder holds (at
    the start, finished runs only) or than the call trained (when it writes: a warning names them at the end); the
    shipped figures are carried, those drawn from rows drawn again from the rows kept; a shipped file of other
    settings is refused."""
    from opnet.experiments import provenance

    budget = dataclasses.replace(BUDGET, ablation_epochs=BUDGET.epochs)  # the ablation's depth 1 shares Table 1's
    monkeypatch.setitem(plan.BUDGETS, "quick", budget)
    options = dict(collection="capsules", refine=False, device="cpu", progress=False)
    first = reproduce.reproduce("quick", tmp_path / "a", ablation_grid="cross", figures=False, **options)
    nets = {r["entry"]: r["provenance"]["runs"] for r in first if r["table"] == "table1" and r.get("run")}
    shipped, context = reproduce.read_results(tmp_path / "a")
    abl = [r for r in shipped if r["table"] == "ablation"]
    here_other = next(r for r in abl if r["provenance"]["runs"] == nets["int+ext"])  # its run here, another training
    later_other = next(r for r in abl if r["provenance"]["runs"] == nets["ext"])  # its run trained again, differently
    for r in (here_other, later_other):  # as if measured on another training: other checkpoints, other inputs
        r["provenance"] |= dict(checkpoints=["0" * 64], inputs="0" * 16)
    shutil.copytree(tmp_path / "a" / "runs", tmp_path / "b" / "runs")
    shutil.rmtree(tmp_path / "b" / "runs" / nets["ext"][0])  # not on this machine: its rows stand until trained
    unfinished = tmp_path / "b" / "runs" / nets["int"][0] / "history.json"  # as if interrupted: best.pt not its result
    unfinished.write_text(json.dumps(json.loads(unfinished.read_text())[:1]))
    for r in shipped:  # so its rows record another checkpoint than the folder's best.pt: not dropped at the start
        if r["provenance"]["runs"] == nets["int"]:
            r["provenance"] |= dict(checkpoints=["0" * 64], inputs="0" * 16)
    monkeypatch.setattr(config, "shipped_presets", lambda collection: ["quick"])
    monkeypatch.setattr(reproduce, "shipped_results", lambda preset, collection: (shipped, context))
    monkeypatch.setattr(reproduce, "shipped_figures", lambda preset, collection: ["ablation", "drawn_elsewhere"])
    monkeypatch.setattr(reproduce, "shipped_figure", lambda name, preset, collection: tmp_path / f"{name}.png")
    for name in ("ablation", "drawn_elsewhere"):
        (tmp_path / f"{name}.png").write_bytes(b"a shipped figure")
    with pytest.raises(ValueError, match="another seeds than this call's"):
        reproduce.reproduce("quick", tmp_path / "refused", seeds=2, from_shipped=True, **options)
    with pytest.warns(UserWarning) as caught:
        rows = reproduce.reproduce("quick", tmp_path / "b", ablation=False, from_shipped=True, **options)
    said = [str(w.message) for w in caught]
    assert any(m.startswith("the shipped quick results: 1 of its") for m in said)  # here_other, at the start
    assert any(m.startswith("2 rows kept from the shipped quick results (ablation)") for m in said)  # Ext, A+C d1
    merged = reproduce.read_results(tmp_path / "b")[0]
    assert merged == json.loads(json.dumps(rows))
    kept = [r for r in merged if r["table"] == "ablation"]
    int_d1 = next(r for r in abl if r["provenance"]["runs"] == nets["int"])  # A+C at depth 1: Table 1's Int
    gone = {report.row_identity(r) for r in (here_other, later_other, int_d1)}
    assert len(kept) == len(abl) - 3 and not gone & {report.row_identity(r) for r in kept}
    assert all(r in shipped for r in kept)  # as the file had them
    bad = [r for r in merged if provenance.superseded(r, provenance.run_checkpoints(tmp_path / "b" / "runs"))]
    assert not bad, [(r["table"], r["entry"], r["provenance"]) for r in bad]
    assert {r["entry"] for r in merged if r["table"] == "table1"} == {
        r["entry"] for r in first if r["table"] == "table1"
    }
    assert (
        "Rows kept from an earlier call carried here from the shipped quick results"
        in (tmp_path / "b" / "results.md").read_text()
    )
    assert (tmp_path / "b" / "figures" / "drawn_elsewhere.png").read_bytes() == b"a shipped figure"
    assert (tmp_path / "b" / "figures" / "ablation.png").stat().st_size > 1000  # drawn again, from the rows kept
    assert (tmp_path / "b" / "figures" / "training_curves.png").stat().st_size > 1000  # this call's own


@pytest.mark.slow
def test_jobs_train_the_plan_side_by_side_into_the_rows_of_one_process(capsules, tmp_path, monkeypatch):
    """--jobs 2 trains every network in two other processes, and the plan evaluates (and writes) each entry once its
    own trainings are finished, while later ones still train; the rows are those of one process, and the ablation's
    A+E+C at depth 1 is Table 1's Int+Ext training, not a second one."""
    torch = pytest.importorskip("torch")
    from opnet.experiments import provenance, runner

    monkeypatch.setitem(plan.BUDGETS, "quick", dataclasses.replace(BUDGET, ablation_epochs=BUDGET.epochs))
    options = dict(collection="capsules", figures=False, refine=False, device="cpu", progress=False)
    one = reproduce.reproduce("quick", tmp_path / "one", **options)
    real = runner.train_run

    def load_only(spec, collection, root, **kw):  # in this process: every run is already finished
        run_dir = spec.run_dir(root, collection)
        assert len(json.loads((run_dir / "history.json").read_text())) == spec.epochs, run_dir.name
        return real(spec, collection, root, **kw)

    monkeypatch.setattr(runner, "train_run", load_only)
    pipelines, written = [], []  # each write of results.json: its entries, and the trainings not yet waited for
    real_init, real_write = reproduce._SideBySide.__init__, reproduce.write_results
    monkeypatch.setattr(
        reproduce._SideBySide, "__init__", lambda self, *a: pipelines.append(self) or real_init(self, *a)
    )
    monkeypatch.setattr(
        reproduce,
        "write_results",
        lambda out, rows, *a: (
            written.append(({r["entry"] for r in rows}, len(pipelines[0].pending))) or real_write(out, rows, *a)
        ),
    )
    two = reproduce.reproduce("quick", tmp_path / "two", jobs=2, **options)
    # each entry is written once its own trainings are done, while later ones still train
    assert next(running for entries, running in written if "int+ext" in entries) > 0
    assert written[-1][1] == 0 and len(written) > 1
    key = lambda r: (r["entry"], r["split"])  # noqa: E731
    assert sorted(map(key, one)) == sorted(map(key, two))
    by = {key(r): r["d_R"] for r in one}
    assert all(r["d_R"] == pytest.approx(by[key(r)], rel=1e-4) for r in two)
    runs = {r["entry"]: r["provenance"]["runs"] for r in two}
    assert runs["ablation-A+E+C-d1"] == runs["int+ext"] and runs["int+ext"][0].startswith("table1-A+E+C-d1-")
    assert not list((tmp_path / "two" / "runs").glob("ablation-A+E+C-d1-*"))
    name = {e.key: e.name for e in reproduce.plan_for(reproduce.ReproduceConfig(**options)).entries}
    assert all(r["method"] == name[r["entry"]] for r in one + two)  # one training, each entry's rows its own name
    # one training left: it too runs in another process, and this process keeps its thread count
    shutil.rmtree(next((tmp_path / "two" / "runs").glob("table1-A+E+C-d1-*")))
    threads = torch.get_num_threads()
    stale = tmp_path / "two" / ".joblib" / "joblib_memmapping_folder_1_killed"  # what a SIGKILLed call leaves
    stale.mkdir(parents=True)
    (stale / "operators.pkl").write_bytes(b"x" * 1000)
    again = reproduce.reproduce("quick", tmp_path / "two", jobs=2, **options)  # its rows stood until trained again
    checkpoints = provenance.run_checkpoints(tmp_path / "two" / "runs")
    assert all(provenance.current(r, checkpoints) for r in again)  # each row of the training the folder now holds
    assert torch.get_num_threads() == threads
    assert (tmp_path / "two" / ".joblib").is_dir() and not stale.exists()  # joblib's maps on disk, old ones deleted
    assert sorted(map(key, again)) == sorted(map(key, two))


@pytest.mark.slow
def test_jobs_interrupted_after_hours_keeps_the_rows_it_measured_and_resumes_to_them(capsules, tmp_path, monkeypatch):
    """--jobs 2 interrupted while the ablation's networks still train (Ctrl-C in the wait): results.json already
    holds Table 1's rows (and any ablation entry whose networks had finished), the trainings not waited for stop
    with it (no warning), and a second call measures the rest, keeping those rows, to the rows of an uninterrupted
    call."""
    import warnings

    from opnet.experiments import runner

    monkeypatch.setitem(plan.BUDGETS, "quick", dataclasses.replace(BUDGET, ablation_epochs=BUDGET.epochs))
    options = dict(collection="capsules", figures=False, refine=False, device="cpu", progress=False, jobs=2)
    whole = reproduce.reproduce("quick", tmp_path / "whole", **options)
    real_wait = reproduce._SideBySide.wait

    def interrupted(self, entry):
        if entry.table == "ablation" and self.needs[entry.key] & set(self.pending):
            raise KeyboardInterrupt  # as Ctrl-C in the wait for a training still running
        return real_wait(self, entry)

    monkeypatch.setattr(reproduce._SideBySide, "wait", interrupted)
    out = tmp_path / "stopped"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # joblib's "tasks ... have been cancelled" would fail here
        with pytest.raises(KeyboardInterrupt):
            reproduce.reproduce("quick", out, **options)
    kept = reproduce.read_results(out)[0]
    # Table 1's rows are written; of the ablation, at most the entries whose networks happened to finish while
    # Table 1 was waited for (joblib hands back whichever training finishes next), never all of them
    assert {r["table"] for r in kept} <= {"table1", "ablation"} and "int+ext" in {r["entry"] for r in kept}
    ablation = lambda rows: {r["entry"] for r in rows if r["table"] == "ablation"}  # noqa: E731
    assert ablation(kept) < ablation(whole)
    monkeypatch.setattr(reproduce._SideBySide, "wait", real_wait)
    evaluated, real_evaluate = [], runner.evaluate
    monkeypatch.setattr(
        runner, "evaluate", lambda coll, methods, *a, **k: evaluated.append(methods[0].info.get("entry")) or
        real_evaluate(coll, methods, *a, **k)
    )  # fmt: skip
    again = reproduce.reproduce("quick", out, **options)
    key = lambda r: (r["entry"], r["split"])  # noqa: E731
    # a network trained by another worker, one that trained other networks first, may round differently in the last
    # bits (seen: 4e-10 relative; test_train's SIGKILL test trains in fresh processes for this), so rows agree to 1e-6
    assert {key(r): r["d_R"] for r in again} == pytest.approx({key(r): r["d_R"] for r in whole}, rel=1e-6)
    assert evaluated and not {r["entry"] for r in kept} & set(evaluated)  # the rows written are kept, not redone
    assert all(e.startswith("ablation-") for e in evaluated), evaluated


def test_a_second_reproduction_into_one_folder_stops_at_once(tmp_path):
    """One writer per --out: a call into a folder that another holds stops before it loads anything, naming the
    holder; the folder is free again once the holder lets go."""
    out = tmp_path / "out"
    with opnet._files.writer_lock(out, "reproduction (opnet.reproduce)"):
        with pytest.raises(opnet.FolderInUseError, match=r"out is being written by reproduction .*process \d+"):
            reproduce.reproduce("quick", out)
    assert not (out / "runs").exists()  # nothing was begun


def test_figures_carry_the_rows_intervals_as_error_bars():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from opnet.experiments import figures

    def row(split, d_R, low=None, high=None, **fields):
        fields = dict(table="table1", architecture="operatornet", variant="paper", channels=list(opnet.KINDS),
                      depth=1, group="table1", run="table1-A+E+C-d1", refined=None, n_shapes=3) | fields  # fmt: skip
        return dict(fields, split=split, d_R=d_R, d_R_low=low, d_R_high=high)

    rows = [row("test", 1e-4, 0.8e-4, 1.2e-4), row("test_subjects", 2e-4, 1.5e-4, 2.5e-4)]
    fig = figures.generalisation_figure(rows)
    bars = [c for c in fig.axes[0].containers if isinstance(c, matplotlib.container.BarContainer)]
    assert all(c.errorbar is not None for c in bars)
    segments = bars[0].errorbar.lines[2][0].get_segments()  # the test bar's interval, ×10⁻⁴
    assert np.allclose([segments[0][0][1], segments[0][1][1]], [0.8, 1.2])
    abl = [dict(row("test", 3e-4, 2e-4, 4e-4), table="ablation", group="ablation")]
    assert report.ablation_table(abl, "half_width")[0, -1] == pytest.approx(1.0)
    texts = [t.get_text() for t in figures.ablation_figure(abl).axes[0].texts]
    assert texts == ["3\n± 1"]
    assert np.isnan(report.ablation_table([dict(abl[0], d_R_low=None)], "half_width")).all()  # one training: none


def test_an_ensemble_is_told_from_a_row_over_seeds():
    """``seeds`` lists the trainings a row pools (each evaluated apart); ``ensemble`` counts the members of one
    averaged network. The figure names only the latter an ensemble, and an older file's count in ``seeds`` is read as
    ``ensemble``."""
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from opnet.experiments import figures

    assert plan.declare(BUDGET)["bodies-shape-poses-quarter"].fields == dict(
        bodies="shape", poses="quarter", ensemble=2
    )
    base = dict(table="table1", architecture="operatornet", variant="ours", channels=list(opnet.KINDS), depth=1,
                bodies="shape", refined=None, n_shapes=3, d_R=1e-4)  # fmt: skip
    seeded = dict(base, group="bodies-shape", run="a+a-s1", seeds=[0, 1])
    ensemble = dict(base, group="bodies-shape-poses-quarter", poses="quarter", run="b+b-s1", ensemble=2)
    rows = [dict(r, split=s) for r in (seeded, ensemble) for s in ("test", "test_subjects")]
    ticks = [t.get_text() for t in figures.generalisation_figure(rows).axes[0].get_xticklabels()]
    assert "ensemble" not in ticks[0] and "ensemble of 2" in ticks[1]
    old = dict(ensemble, seeds=2)
    del old["ensemble"]
    (upgraded,) = report.upgrade_rows([old])
    assert upgraded["ensemble"] == 2 and "seeds" not in upgraded
    assert report.upgrade_rows([seeded]) == [seeded]


def test_the_generalisation_figure_draws_a_network_over_seeds_its_refinement_and_its_intervals():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    from opnet.experiments import figures

    net = dict(table="table1", architecture="operatornet", variant="paper", channels=list(opnet.KINDS), depth=1,
               group="table1", run="r+r-s1+r-s2", runs=["r", "r-s1", "r-s2"], seeds=[0, 1, 2], n_shapes=9)  # fmt: skip
    wide = dict(d_R=1e-4, d_R_low=-0.5e-4, d_R_high=2.5e-4)  # a spread wider than the mean: the interval reaches 0
    rows = [dict(net, split="test", **wide), dict(net, split="test_subjects", d_R=2e-4, d_R_low=1e-4, d_R_high=3e-4)]
    refined = {k: v for k, v in net.items() if k not in ("channels", "runs", "seeds")}  # it refines the first seed
    rows += [dict(refined, run="r", refined=True, split=s, d_R=0.5e-4, n_shapes=3) for s in ("test", "test_subjects")]
    disc = dict(net, table="discretisation", split="test", method="OperatorNet (Int+Ext)", n_shapes=4)
    rows += [
        dict(disc, resolution=res, maps=maps, d_R=1e-4, d_R_low=0.8e-4, d_R_high=1.2e-4)
        for res, maps in (("1k", "exact"), ("5k", "computed"))
    ]
    left, right = figures.generalisation_figure(rows).axes
    bars = [c for c in left.containers if isinstance(c, matplotlib.container.BarContainer)]
    assert [len(c) for c in bars] == [2, 2]  # the network and its refinement, on both test sets
    assert "+ refinement" in left.get_xticklabels()[1].get_text()
    low, high = (y for y in bars[0].errorbar.lines[2][0].get_segments()[0][:, 1])  # the network's test bar, ×10⁻⁴
    assert low == pytest.approx(0.01) and high == pytest.approx(2.5)  # drawn down to a hundredth of the mean
    (line,) = right.containers  # the discretisation row's line, with its intervals as error bars
    assert line.has_yerr
    segments = line.lines[2][0].get_segments()
    assert [tuple(np.round(s[:, 1], 6)) for s in segments] == [(0.8, 1.2), (0.8, 1.2)]


def test_budgets_name_their_schedule_seeds_and_grid_and_the_papers_code_budget_is_named():
    default = plan.BUDGETS["default"]
    assert default.schedule == "onecycle" and default.ablation_epochs == default.epochs  # the ablation at Table 1's
    d = plan.declare(default, seeds=default.seeds, ablation_grid=default.ablation_grid)
    assert d["int+ext"].spec.schedule == "onecycle" and d["pointnet"].spec.schedule == "onecycle"
    assert d["ours"].spec.schedule is None  # our variant keeps its own one-cycle rate
    cross = [e for e in d.entries if e.table == "ablation"]
    assert len(cross) == len(plan.ABLATION_SETS) + len(plan.ABLATION_DEPTHS) - 1  # depth 1's row, A+E+C's column
    assert {(e.spec.depth, e.spec.channel_names) for e in cross if e.spec.depth > 1} == {
        (depth, opnet.KINDS) for depth in plan.ABLATION_DEPTHS[1:]
    }
    assert len([e for e in plan.declare(default).entries if e.table == "ablation"]) == 28  # the full grid
    with pytest.raises(ValueError, match="grid must be one of"):
        plan.declare(default, ablation_grid="diagonal")
    # the preset's seeds and grid unless told; the paper's code's budget by name, its evaluation the preset's
    c = config.ReproduceConfig(preset="default")
    assert (c.seeds, c.ablation_grid) == (3, "cross") and config.ReproduceConfig(preset="quick").seeds == 1
    assert config.ReproduceConfig(preset="default", seeds=1, ablation_grid="full").seeds == 1
    code = config.ReproduceConfig(preset="paper", training_budget="paper-code").training
    assert (code.epochs, code.lr, code.batch_size, code.schedule) == (450, 1e-4, 32, "constant")
    assert code.analogies == plan.BUDGETS["paper"].analogies
    with pytest.raises(ValueError, match="paper-code"):
        config.ReproduceConfig(training_budget="papers")
    # a claim "within 5×" is annotated against five times the other's mean
    from opnet.experiments import claims

    rows = [
        dict(table="table1", split="test", d_R=3e-4, **plan.PAPER_ROWS["OperatorNet (Comp)(Int+Ext)"]),
        dict(table="table1", split="test", d_R=1e-4, **plan.PAPER_ROWS["OperatorNet (Int+Ext)"]),
    ]
    line = next(x for x in claims.claims_markdown(rows) if "within 5×" in x)
    assert "3 / 5 × 1" in line and "(means: holds)" in line
    nan = dict(rows[0], d_R=float("nan"))  # a mean not measured (NaN) holds nothing, and prints as missing
    line = next(x for x in claims.claims_markdown([nan, rows[1]]) if "within 5×" in x)
    assert "– / 5 × 1" in line and "(means:" not in line and "inconclusive" in line
    pytest.importorskip("torch")  # the command line's parser holds `train`
    args = _parser().parse_args(["reproduce", "--budget", "paper-code", "--ablation-grid", "cross"])
    assert (args.training_budget, args.ablation_grid) == ("paper-code", "cross")


def test_the_headline_prints_a_seeded_rows_interval_and_says_so():
    base = dict(table="table1", architecture="operatornet", variant="paper", group="table1", run="r", n_shapes=4)
    base |= dict(method="OperatorNet", channels=list(opnet.KINDS), depth=1, d_V=0.01, d_E=0.02)
    one = [dict(base, split=s, d_R=1e-4) for s in ("test", "test_subjects")]
    lines = report.headline_markdown(one)
    assert len(lines) == 3 and lines[2].startswith("| OperatorNet | 1 | 0.01 | 0.02 | 1 |")  # one training: its means
    seeded = [dict(r, d_R_low=0.5e-4, d_R_high=1.5e-4, seeds=[0, 1, 2]) for r in one]
    lines = report.headline_markdown(seeded)
    assert lines[2].startswith("| OperatorNet | 1 ± 0.5 | 0.01 | 0.02 | 1 ± 0.5 |")
    assert lines[-1].startswith("d_R ×10⁻⁴ m²; a network trained with several seeds: mean ± half-width")


def test_the_provenance_line_gives_the_dates_machine_and_budget_of_old_and_new_files():
    old = dict(preset="default", date="2026-12-03", machine="CPU", earlier=[dict(date="2026-12-02")])
    old["budget"] = dict(epochs=60, lr=1e-3, batch_size=32)  # written before schedules and seeds were recorded
    assert report.provenance_text(old) == (
        "Measured from 2026-12-02 to 2026-12-03 on CPU, at the `default` preset's budget then: 60 epochs, a "
        "constant lr 0.001 for the paper's networks (one-cycle with peak 0.001 for ours), batch 32, one seed each."
    )
    new = dict(old, earlier=[], seeds=3, budget=dict(old["budget"], schedule="onecycle", seeds=3))
    assert report.provenance_text(new).startswith("Measured on 2026-12-03 on CPU")
    assert "60 epochs, onecycle schedule with peak lr 0.001 for every network, batch 32, each with 3 seeds (0–2)." in (
        report.provenance_text(new)
    )
    assert "an unrecorded budget" in report.provenance_text(dict(preset="quick"))
    rows = [dict(table="table1", architecture="operatornet", variant="paper", group="table1", run="r", n_shapes=4,
                 method="OperatorNet", channels=list(opnet.KINDS), depth=1, d_R=1e-4, d_V=0.01, d_E=0.02, split=s)
            for s in ("test", "test_subjects")]  # fmt: skip
    assert report.headline_markdown(rows, new)[-1] == report.provenance_text(new)


def test_a_run_stopped_and_resumed_lists_its_neighbouring_earlier_calls_on_one_line():
    from opnet.experiments import shipped

    call = dict(tables=["table1", "analogy"], date="2026-12-06", machine="CPU")
    other = dict(call, date="2026-12-05", wall_seconds=7.0)
    earlier = [other, dict(call, wall_seconds=10445.0), dict(call, wall_seconds=86.4), dict(call), dict(other)]
    context = dict(shipped.shipped_results("default")[1], earlier=earlier)
    lines = [line for line in report.context_markdown(context) if line.startswith("Rows kept")]
    start = "Rows kept from {} in the same folder (finished runs reused): the tables table1, analogy, measured on "
    assert lines == [  # oldest first; only neighbours share a line
        start.format("an earlier call") + "2026-12-05 on CPU, wall time 7 s.",
        start.format("3 earlier calls") + "2026-12-06 on CPU, wall times 10445, 86 s (1 not recorded).",
        start.format("an earlier call") + "2026-12-05 on CPU, wall time 7 s.",
    ]


def _rows_of(rows: list[dict]) -> list[tuple]:
    return [(r["table"], r.get("kind"), r["entry"], r.get("split")) for r in rows]


def test_merged_rows_follow_this_calls_order_and_keep_the_others_behind_their_neighbours():
    """A file written in the order measured (``reproduce --points`` after the rest: the transformer's PointNet at the
    end) is merged into this call's order, its rows beside their plan neighbours; a part this call left out (the
    ablation) keeps its place behind the row before it; the applications' rows take this call's order, the truth
    row of each kind first."""
    context = dict(preset="quick", budget={}, splits={}, collection="c")

    def row(table, entry, split=None, kind=None):
        return dict(table=table, entry=entry, method=str(entry), split=split, kind=kind)

    table1 = [row("table1", e, s) for e in ("int+ext", "pointnet", "pointnet-stn", "nn") for s in ("test", "other")]
    apps = [row("interpolation", e, kind=k) for k in ("pose", "body") for e in (None, "pointnet", "pointnet-stn")]
    ablation = [row("ablation", "ablation-A-d1", "test")]
    old = [r for r in table1 if r["entry"] != "pointnet-stn"] + [r for r in apps if r["entry"] != "pointnet-stn"]
    old += ablation + [r for r in table1 if r["entry"] == "pointnet-stn"]  # the order in which they were measured
    rows, merged = report.merge_results((old, dict(context, date="2026-12-06")), table1 + apps, context)
    assert _rows_of(rows) == _rows_of(table1 + apps + ablation)
    assert merged["earlier"][-1]["tables"] == ["ablation"]
    partial = table1[:4] + table1[6:]  # while the later entries are still measured: nothing lost, none twice
    rows, _ = report.merge_results((old, dict(context)), partial, context)
    assert sorted(_rows_of(rows), key=str) == sorted(_rows_of(old), key=str)
    assert _rows_of(rows)[:6] == _rows_of(table1[:4] + table1[6:])


def test_results_json_keeps_per_shape_errors_to_seven_digits_on_one_line_each(tmp_path):
    from opnet.experiments import shipped

    rows, context = shipped.shipped_results("default")
    rng = np.random.default_rng(0)
    errors = rng.gamma(2.0, 1e-4, (3, 200))
    errors[0, 5] = np.nan  # d_V of an open mesh
    row = dict(rows[0], d_R_shapes=errors.tolist(), shapes=list(range(200)), seeds=[0, 1, 2], note="kept as it is")
    other = dict(rows[1], d_R_shapes=[[1.0, 2.0]], shapes=[7, 8])  # each row's lists go back in their own place
    report.write_results(tmp_path, [row, other], context, 1.0)
    text = (tmp_path / "results.json").read_text()
    lines = text.splitlines()  # 600 errors and 200 indices, but a line per list, whatever else the rows hold
    errors_line, shapes_line = (next(line for line in lines if f'"{key}"' in line) for key in ("d_R_shapes", "shapes"))
    assert errors_line.count(",") == 600 and shapes_line.count(",") == 200  # the numbers, and the comma after the list
    (back, back_other), context = report.read_results(tmp_path)
    assert back_other["d_R_shapes"] == [[1.0, 2.0]] and back_other["shapes"] == [7, 8]
    assert back["d_R"] == row["d_R"] and back["shapes"] == row["shapes"] and back["note"] == "kept as it is"
    got = np.array(back["d_R_shapes"], dtype=float)
    assert np.isnan(got[0, 5]) and np.allclose(got, errors, rtol=1e-6, atol=0, equal_nan=True)
    assert not np.array_equal(got, errors, equal_nan=True)  # rounded: seven significant digits
    assert context["wall_seconds"] == 1.0


def test_table1_lists_each_seeds_error_under_the_table():
    base = dict(table="table1", architecture="operatornet", variant="paper", group="table1", method="OperatorNet",
                channels=list(opnet.KINDS), depth=1, d_R_median=1e-4, d_V=0.01, d_E=0.02, n_shapes=4,
                train_seconds=10.0, seconds_per_shape=0.001)  # fmt: skip
    seeded = dict(base, run="r+r-s1+r-s2", split="test", d_R=2e-4, d_R_low=1e-4, d_R_high=3e-4)
    seeded |= dict(d_R_seeds=[1e-4, 2e-4, 3e-4], d_R_std=1e-4, seeds=[0, 1, 2])
    lines = report.table1_markdown([seeded, dict(base, run="one", method="One", split="test", d_R=1e-4)])
    assert lines[-1] == "- OperatorNet: 1, 2, 3 (seeds 0, 1, 2; sd 1)"  # a training: anywhere in that range
    assert lines[-2].startswith("Seed to seed, `test` d_R") and not any(x.startswith("- One") for x in lines)
    assert "Seed to seed" not in "\n".join(report.table1_markdown([dict(base, run="one", split="test", d_R=1e-4)]))
