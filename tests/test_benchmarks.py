"""The benchmark scripts the docs show: what they measure is right, and each shipped result renders.

Timings are not asserted (they belong to the benchmarks); what is tested is that the fast path the shape-difference
benchmark times computes the explicit formula's operators, and that every ``benchmarks/results/<script>.json``
still renders through its script's ``report`` (the docs' benchmarks page does this at every build).
"""

import importlib
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
NEEDS = {"torch_ops": "torch", "pointnet": "torch", "point_steps": "torch", "training": "torch"}


def script(name: str):
    """``benchmarks/<name>.py`` as a module (the scripts import each other by file name, as when run)."""
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    if name in NEEDS:
        pytest.importorskip(NEEDS[name])
    return importlib.import_module(name)


def test_the_shape_difference_benchmark_checks_the_fast_path_against_the_explicit_formula(capsys):
    bench = script("shape_differences")
    args = bench.parse_args(["--quick", "--n-shapes", "8", "--n-explicit", "1", "--repeats", "1", "--batch-size", "4"])
    result = bench.measure(args)
    fast = [r for r in result["rows"] if "share_of_dense_rate" in r]  # with and without the shape checks
    assert len(fast) == 8 and all(r["max_rel_diff"] < 1e-12 for r in fast)
    assert all(r["speedup"] > 1 for r in fast)  # no full eigendecomposition: faster by construction
    assert all(0 < r["share_of_dense_rate"] for r in fast) and result["dense_rate_gflops"]["used"] > 0
    report = bench.report(json.loads(json.dumps(result)))  # as the docs read it back
    assert report.count("| opnet fast path") == 4 and "faster than the explicit formula" in report
    assert "dense-product rate" in report


def test_the_fast_path_work_is_counted_as_its_products():
    bench = script("shape_differences")
    n, e, k = 100, 300, 10
    # area: weights (n) times the table (n, k(k+1)/2), two flops a term; then K₀⁺ K, 2k³
    assert bench.fast_path_flops(n, e, k, ("area",)) == 2 * n * k * (k + 1) // 2 + 2 * k**3
    assert bench.fast_path_flops(n, e, k, ("conformal",)) == 2 * e * k * (k + 1) // 2 + 2 * k**3
    both = bench.fast_path_flops(n, e, k, ("area", "extrinsic"))
    assert both == 2 * bench.fast_path_flops(n, e, k, ("area",)) + 10 * n * k


@pytest.mark.parametrize("path", sorted((BENCHMARKS / "results").glob("*.json")), ids=lambda p: p.stem)
def test_every_shipped_benchmark_result_renders(path):
    result = json.loads(path.read_text())
    report = script(path.stem.partition("-")[0]).report(result)  # <script>-<what>: one script at other settings
    assert "|---" in report and result["date"] in report


@pytest.mark.slow
def test_the_offset_channel_benchmark_trains_each_set_and_reports_it_against_the_papers(tmp_path):
    bench = script("offset_channels")
    args = bench.parse_args(["--preset", "quick", "--runs", str(tmp_path), "--epochs", "1"])
    result = json.loads(json.dumps(bench.measure(args)))  # as the docs read it back
    nets = [r for r in result["rows"] if r["method"] == "OperatorNet"]
    assert {(r["channels"], r["split"]) for r in nets} == {(c, s) for c in bench.SETS for s in bench.SPLITS}
    assert all(r["epochs"] == 1 and r["train_seconds"] > 0 and r["d_R"] > 0 for r in nets)
    assert sum(r["method"] == "Nearest neighbour" for r in result["rows"]) == len(nets)
    report = bench.report(result)
    assert report.count("| OperatorNet |") == 3 and "Int+Off's d_R / on Int+Ext's" in report


def test_the_schedule_rule_takes_the_best_converged_candidate_and_fewer_epochs_within_the_spread():
    bench = script("schedules")

    def rows(name, epochs, vals, converged=True):
        return [
            dict(
                candidate=name,
                schedule="x",
                epochs=epochs,
                seed=s,
                best_val=v,
                converged=converged,
                train_s=1.0,
                tail_ratio=1.0 if converged else 2.0,
            )  # fmt: skip
            for s, v in enumerate(vals)
        ]

    jumping = rows("constant-60", 60, [0.8, 1.2, 1.0], converged=False)  # the lowest seed, but never settles
    assert bench.choose(jumping + rows("onecycle-60", 60, [1.0, 1.1, 1.2])) == "onecycle-60"
    # half the epochs within the seeds' spread of the best: the cheaper one; far outside it: the best
    assert bench.choose(rows("onecycle-30", 30, [1.05, 1.15, 1.25]) + rows("onecycle-60", 60, [1.0, 1.1, 1.2])) == (
        "onecycle-30"
    )
    assert bench.choose(rows("onecycle-30", 30, [2.0, 2.1, 2.2]) + rows("onecycle-60", 60, [1.0, 1.1, 1.2])) == (
        "onecycle-60"
    )
    assert bench.choose(jumping) is None


def test_convergence_measures_the_tail_against_the_best():
    pytest.importorskip("torch")
    from opnet.train import convergence

    flat = [dict(epoch=e + 1, val_d_R=v) for e, v in enumerate([5.0, 3.0, 2.0, 1.0, 1.02, 1.01, 1.0, 1.03, 1.0, 1.04])]
    c = convergence(flat)
    assert c.converged and c.tail_epochs == 1 and c.best_epoch == 4 and c.tail_ratio == pytest.approx(1.04)
    jumping = flat[:-1] + [dict(epoch=10, val_d_R=1.3)]
    assert not convergence(jumping).converged and convergence(jumping, tail=0.5).tail_epochs == 5
    with pytest.raises(ValueError, match="tail must be"):
        convergence(flat, tail=0)
    with pytest.raises(ValueError, match="history is empty"):
        convergence([])


def test_the_matching_benchmark_finds_each_networks_first_seed_by_the_plan(tmp_path, tiny_collection):
    """benchmarks/matching.py --runs decodes with Table 1's networks: each found as the reproduction declares its
    first seed's run (its folder name carries a digest), a finished one loaded, a missing or unfinished one skipped, a
    later seed's folder never taken for it."""
    pytest.importorskip("torch")  # the run's digest fingerprints the collection with opnet.train
    from opnet.reproduce import BUDGETS, declare

    matching = script("matching")
    ds = tiny_collection()
    plan = declare(BUDGETS["quick"], seeds=2)
    first, second = plan["int+ext"].spec.replicates()
    ext = plan["ext"].spec.replicates()[0]
    for spec, history in ((first, 80), (second, 80), (ext, 3)):  # ext: still training
        run = spec.run_dir(tmp_path, ds)
        run.mkdir()
        (run / "config.json").write_text(json.dumps({"train": {"epochs": 80}}))
        (run / "history.json").write_text(json.dumps([{}] * history))
        (run / "best.pt").write_bytes(b"")
    done, skipped = matching.finished_runs(tmp_path, ds, "quick")
    assert done == {"Int+Ext": first.run_dir(tmp_path, ds)} and done["Int+Ext"].name.startswith("table1-A+E+C-d1-")
    assert len(skipped) == 3 and ext.run_dir(tmp_path, ds).name in skipped  # Int, ours: not there
