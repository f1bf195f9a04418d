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
NEEDS = {"torch_ops": "torch", "pointnet": "torch", "training": "torch"}


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
    report = script(path.stem).report(result)
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
