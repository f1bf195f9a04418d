"""Benchmark: shape-difference operators, fast path vs the explicit formula (and pyFM).

Measures, side by side and in one run, on the ~1000-vertex toy capsule
(``opnet.data.toy.capsule("default")``; the vertex count is printed) and a batch of smoothly bent and
inflated copies of it (``toy.bend`` / ``toy.bulge`` with random parameters from a seeded
``numpy.random.Generator``), for a base eigenbasis of ``k = 60`` functions:

1. the fast path ``opnet.shape_differences(base_basis, vertices, channels=...)`` — shapes per
   second for the three operators together and for each one alone (best of 3 repeats,
   after a warm-up call) — and the same without its checks of the shapes
   (``opnet.shape_difference.fast_path``, what ``Collection.with_channels`` runs on a collection's
   shapes, checked when it was built);
2. the explicit formula as the authors' code evaluates it: for each target its full dense
   eigendecomposition (``opnet.eigenbasis(target, n)``), ``opnet.identity_fmap`` and then
   ``opnet.shape_difference(base_basis, target, kind, fmap=fmap)`` — seconds per shape on
   a few shapes;
3. the speed-up (explicit s/shape ÷ method s/shape, same operators) and the largest
   relative difference ``‖D_method − D_explicit‖_F / ‖D_explicit‖_F`` over the shapes
   timed by the explicit formula;
4. if pyFM (PyPI ``pyfmaps``) is importable, its ``area_SD`` / ``conformal_SD`` on the same
   functional maps and eigenvalues (the maps and eigendecompositions are given to it, so
   those rows time the last step only; one more row adds the measured cost of the
   eigendecomposition and functional map).

In the same run it measures the machine's own dense-product rate (numpy's float64 product of
two 2000 × 2000 matrices, GFLOP/s, best of 3, before and after the fast path) and gives each
fast-path row its share of it: the floating-point work of the fast path's matrix products
(:func:`fast_path_flops`) times its shapes per second, over that rate.

Prints a Markdown table, machine information and whether the project's targets are met
(fast path ≥ 100× faster than the explicit formula, ≥ 2000 shapes/s for all three operators
together and ≥ 30 % of the dense-product rate). ``--json PATH`` also writes everything as
JSON. If the throughput target is missed (or with ``--profile``) the fast path is profiled with
cProfile.

Run::

    .venv/bin/python benchmarks/shape_differences.py            # full run (~30 s on 2 idle cores)
    .venv/bin/python benchmarks/shape_differences.py --quick    # smoke run (< 30 s)
    .venv/bin/python benchmarks/shape_differences.py --json results.json --profile
"""

from __future__ import annotations

import argparse
import cProfile
import io
import json
import os
import platform
import pstats
import sys
import time
from pathlib import Path

import numpy as np
import scipy

import opnet
from opnet.data import toy
from opnet.shape_difference import fast_path

KINDS = ("area", "conformal", "extrinsic")
TARGET_SPEEDUP = 100.0
TARGET_THROUGHPUT = 2000.0  # shapes/s, all three operators together
TARGET_FRACTION = 0.30  # of the machine's dense-product rate
DENSE_SIZE = 2000  # the dense product that measures the machine's rate: (2000 × 2000) @ (2000 × 2000)


# ---- data -------------------------------------------------------------------------------------------


def make_shapes(base: opnet.Mesh, n: int, seed: int) -> np.ndarray:
    """``n`` smooth deformations ``(n, n_vertices, 3)`` of ``base``: a random bulge, then a random bend.

    Only the amount/position parameters are drawn (widths keep ``toy``'s defaults), from a
    seeded ``numpy.random.Generator``, so the same seed gives the same shapes.
    """
    rng = np.random.default_rng(seed)
    z = base.vertices[:, 2]
    lo, hi = z.min(), z.max()
    out = np.empty((n, *base.vertices.shape))
    for i in range(n):
        v = toy.bulge(base.vertices, amount=rng.uniform(-0.2, 0.4), center=lo + (hi - lo) * rng.uniform(0.2, 0.8))
        v = toy.bend(v, angle=rng.uniform(-np.pi / 2, np.pi / 2), joint=lo + (hi - lo) * rng.uniform(0.3, 0.7))
        out[i] = v
    return out


# ---- timing helpers -----------------------------------------------------------------------------------


def best_of(fn, repeats: int) -> float:
    """Best wall time of ``repeats`` calls of ``fn`` (after the caller's warm-up)."""
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def rel_diff(a: np.ndarray, b: np.ndarray) -> float:
    """``‖a − b‖_F / ‖b‖_F`` over the last two axes, maximised over the leading ones."""
    num = np.linalg.norm(a - b, axis=(-2, -1))
    den = np.linalg.norm(b, axis=(-2, -1))
    return float(np.max(num / den))


def time_fast(base_basis, shapes, channels, repeats, batch_size, *, checked: bool = True):
    """Seconds per shape of ``opnet.shape_differences`` (``checked``) or of the fast path without the checks."""
    ips = opnet.inner_products.get_inner_products(channels)

    def run(some=shapes):
        if checked:
            return opnet.shape_differences(base_basis, some, channels=channels, batch_size=batch_size, progress=False)
        return fast_path(base_basis, some, ips, batch_size=batch_size)

    run(shapes[:batch_size])  # warm-up: the product tables of the basis are built once
    return best_of(run, repeats) / len(shapes)


def dense_rate(repeats: int = 3) -> float:
    """GFLOP/s of numpy's float64 product of two ``DENSE_SIZE`` square matrices (best of ``repeats``)."""
    a, b = np.random.default_rng(0).random((2, DENSE_SIZE, DENSE_SIZE))
    a @ b  # warm-up
    return 2 * DENSE_SIZE**3 / best_of(lambda: a @ b, repeats) / 1e9


def fast_path_flops(n_vertices: int, n_edges: int, k: int, channels) -> float:
    """Floating-point operations per shape of the fast path's matrix products for ``channels``.

    Each Gram ``Φᵀ diag(w) Φ`` is one product of the weights with a table of the ``k (k + 1) / 2`` column products
    of ``Φ`` (``n`` rows for area and extrinsic, one per edge for conformal): ``2 rows · k (k + 1) / 2``; the
    extrinsic one also projects five columns (``2 · 5 n k``); each channel then takes ``K₀⁺ K`` (``2 k³``). The
    per-vertex and per-face arithmetic (areas, cotangents) is not counted: it is the overhead.
    """
    rows = {"area": n_vertices, "conformal": n_edges, "extrinsic": n_vertices}
    return sum(
        rows[kind] * k * (k + 1) + 2 * k**3 + (10 * n_vertices * k if kind == "extrinsic" else 0) for kind in channels
    )


def explicit_one(base_basis, mesh, timings):
    """Explicit shape differences ``(3, k, k)`` of one target; adds stage times to ``timings``."""
    t0 = time.perf_counter()
    tb = opnet.eigenbasis(mesh, mesh.n_vertices)  # full, dense
    t1 = time.perf_counter()
    fmap = opnet.identity_fmap(base_basis, tb)
    t2 = time.perf_counter()
    timings["eigendecomposition"] += t1 - t0
    timings["fmap"] += t2 - t1
    D = []
    for kind in KINDS:
        t = time.perf_counter()
        D.append(opnet.shape_difference(base_basis, mesh, kind, fmap=fmap))
        timings[kind] += time.perf_counter() - t
    return np.stack(D), fmap


def time_explicit(base_basis, base, shapes):
    stages = dict.fromkeys(("eigendecomposition", "fmap", *KINDS), 0.0)
    explicit_one(base_basis, base.with_vertices(shapes[-1]), dict(stages))  # warm-up (result discarded)
    meshes = [base.with_vertices(v) for v in shapes]
    Ds, fmaps = [], []
    t = time.perf_counter()
    for m in meshes:
        D, fmap = explicit_one(base_basis, m, stages)
        Ds.append(D)
        fmaps.append(fmap)
    total = time.perf_counter() - t
    n = len(shapes)
    return np.stack(Ds), fmaps, total / n, {k: v / n for k, v in stages.items()}


# ---- pyFM -----------------------------------------------------------------------------------------------


def import_pyfm():
    """pyFM's ``(area_SD, conformal_SD, version)``, or ``None`` and a note why not."""
    try:
        import pyFM  # noqa: F401
    except Exception as exc:  # not installed, or broken install
        return None, f"pyFM not importable ({type(exc).__name__}: {exc}); install with `pip install pyfmaps`."
    try:
        from pyFM.spectral import area_SD, conformal_SD
    except Exception:
        try:
            from pyFM.spectral.shape_difference import area_SD, conformal_SD
        except Exception as exc:
            return None, f"pyFM is installed but has no area_SD/conformal_SD ({exc})."
    try:
        from importlib.metadata import version

        ver = version("pyfmaps")
    except Exception:
        ver = getattr(sys.modules["pyFM"], "__version__", "unknown")
    return (area_SD, conformal_SD, ver), None


def time_pyfm(fns, base_basis, fmaps, inner_loops=200, repeats=3):
    """Per-shape seconds of pyFM's SDs on given maps, and the SDs ``(n, 2, k, k)``."""
    area_SD, conformal_SD, _ = fns
    ev0 = base_basis.evals
    Cs = [f.matrix for f in fmaps]
    evs = [f.target.evals for f in fmaps]
    out = np.stack([np.stack([area_SD(C), conformal_SD(C, ev0, ev)]) for C, ev in zip(Cs, evs)])

    def loop(which):
        def run():
            for _ in range(inner_loops):
                for C, ev in zip(Cs, evs):
                    if which in ("area", "both"):
                        area_SD(C)
                    if which in ("conformal", "both"):
                        conformal_SD(C, ev0, ev)

        return run

    per_shape = {}
    for which in ("area", "conformal", "both"):
        loop(which)()  # warm-up
        per_shape[which] = best_of(loop(which), repeats) / (inner_loops * len(Cs))
    return per_shape, out


# ---- profiling ------------------------------------------------------------------------------------------


def profile_fast(base_basis, shapes, batch_size, top=18):
    """cProfile of the fast path: its text report and the top functions by own time."""
    pr = cProfile.Profile()
    pr.enable()
    opnet.shape_differences(base_basis, shapes, channels=KINDS, batch_size=batch_size, progress=False)
    pr.disable()
    s = io.StringIO()
    st = pstats.Stats(pr, stream=s).sort_stats("tottime")
    st.print_stats(top)
    rows = []
    for (file, line, func), (cc, nc, tt, ct, _) in sorted(st.stats.items(), key=lambda kv: -kv[1][2])[:top]:
        rows.append({"function": f"{Path(file).name}:{line}({func})", "calls": nc, "tottime_s": tt, "cumtime_s": ct})
    return s.getvalue(), rows


# ---- report ------------------------------------------------------------------------------------------------


class OtherLoad:
    """CPU time used by *other* processes while the benchmark runs, as a fraction of all CPUs (Linux)."""

    def __init__(self):
        self.start = self._sample()

    @staticmethod
    def _sample():
        try:
            with open("/proc/stat") as f:
                vals = [int(x) for x in f.readline().split()[1:]]
        except (OSError, ValueError):
            return None
        hz = os.sysconf("SC_CLK_TCK")
        t = os.times()
        return (sum(vals) - vals[3] - vals[4]) / hz, t.user + t.system, time.perf_counter()

    def fraction(self) -> float | None:
        end = self._sample()
        if self.start is None or end is None:
            return None
        busy, own, wall = (e - s for e, s in zip(end, self.start))
        return max(busy - own, 0.0) / (wall * (os.cpu_count() or 1))


def machine_info(pyfm_version):
    info = {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "cpus_usable": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "opnet": opnet.__version__,
        "pyfmaps": pyfm_version,
    }
    if hasattr(os, "getloadavg"):
        info["loadavg_1min_at_start"] = round(os.getloadavg()[0], 2)
    probe = OtherLoad()
    time.sleep(1.0)
    busy = probe.fraction()
    if busy is not None:  # CPU used by other processes over one second before the benchmark
        info["cpu_busy_at_start"] = f"{100 * busy:.0f} %"
    try:  # optional: which BLAS and how many threads
        from threadpoolctl import threadpool_info

        info["blas"] = [
            f"{p.get('internal_api')} {p.get('version')} ({p.get('num_threads')} threads)"
            for p in threadpool_info()
            if p.get("user_api") == "blas"
        ]
    except Exception:
        pass
    return info


def torch_machine_info() -> dict:
    """:func:`machine_info` with torch's version and its thread count: the machine line of the benchmarks that train
    or run torch."""
    import torch

    return machine_info(None) | {"torch": torch.__version__, "torch_threads": torch.get_num_threads()}


def measured(date: str, machine: dict) -> str:
    """The line saying when and on what a result was measured."""
    return f"Measured {date}: " + "; ".join(f"{k} {v}" for k, v in machine.items() if v is not None) + "."


def load_span(machine: dict) -> str:
    """``load average A at the start, B at the end``: the machine's 1-minute load around a measurement."""
    start, end = machine.get("loadavg_1min_at_start"), machine.get("loadavg_1min_at_end")
    return f"load average {start} at the start, {end} at the end"


def save(result: dict, path) -> None:
    """Write ``result`` as JSON to ``path`` (the ``--json`` option of the benchmarks), creating its folder."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps(result, indent=2))
    print(f"\nJSON written to {path}")


def run_benchmark(title: str, parse_args, measure, report, argv=None) -> tuple:
    """Parse ``argv``, measure, print the title and the report, write ``--json`` when asked: the benchmarks' main.

    Returns ``(args, result)``.
    """
    args = parse_args(argv)
    result = measure(args)
    print(f"# {title}{' (--quick)' if getattr(args, 'quick', False) else ''}\n")
    print(report(result))
    if args.json:
        save(result, args.json)
    return args, result


def fmt_rate(x):
    return f"{x:,.1f}" if x < 1e4 else f"{x:,.0f}"


def fmt_sec(x):
    return f"{x * 1e3:.3f} ms" if x < 1 else f"{x:.3f} s"


def markdown_table(rows):
    head = (
        "| method | operators | shapes/s | s/shape | speed-up vs explicit | max rel. diff vs explicit "
        "| share of the dense-product rate |"
    )
    lines = [head, "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        sp_ = "—" if r["speedup"] is None else f"{r['speedup']:,.0f}×" if r["speedup"] >= 10 else f"{r['speedup']:.2f}×"
        rd = (
            "—"
            if r["max_rel_diff"] is None
            else ("0 (reference)" if r["max_rel_diff"] == 0 else f"{r['max_rel_diff']:.1e}")
        )
        share = r.get("share_of_dense_rate")
        lines.append(
            f"| {r['method']} | {r['operators']} | {fmt_rate(1 / r['s_per_shape'])} | "
            f"{fmt_sec(r['s_per_shape'])} | {sp_} | {rd} | {'—' if share is None else f'{100 * share:.0f} %'} |"
        )
    return "\n".join(lines)


def parse_args(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--quick", action="store_true", help="short smoke run (< 30 s): fewer shapes")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    ap.add_argument("--n-shapes", type=int, help="shapes for the fast path (default 500; 100 with --quick)")
    ap.add_argument("--n-explicit", type=int, help="shapes for the explicit formula (default 5; 3 with --quick)")
    ap.add_argument(
        "--preset", default="default", help="toy.capsule resolution preset (default 'default', ~1000 vertices)"
    )
    ap.add_argument("--k", type=int, default=60, help="size of the base eigenbasis (default 60)")
    ap.add_argument("--repeats", type=int, default=3, help="repeats for the fast path; the best is kept (default 3)")
    ap.add_argument("--batch-size", type=int, default=128, help="batch_size passed to shape_differences (default 128)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the shape generator (default 0)")
    ap.add_argument("--profile", action="store_true", help="profile the fast path even if the throughput target is met")
    ap.add_argument("--strict", action="store_true", help="exit with status 1 if a target is missed")
    return ap.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""
    n_shapes = args.n_shapes or (100 if args.quick else 500)
    n_explicit = args.n_explicit or (3 if args.quick else 5)
    fns, pyfm_note = import_pyfm()
    info = machine_info(fns[2] if fns else None)
    busy = "cpu_busy_at_start" in info and float(info["cpu_busy_at_start"].rstrip(" %")) > 20
    if busy:
        print(
            f"WARNING: {info['cpu_busy_at_start']} of the CPUs were busy with other processes just before the "
            "benchmark started; the timings below may be pessimistic: rerun on an idle machine.\n",
            flush=True,
        )
    monitor = OtherLoad()
    base = toy.capsule(args.preset)
    base_basis = opnet.eigenbasis(base, args.k)
    shapes = make_shapes(base, max(n_shapes, n_explicit), args.seed)
    for v in shapes[:n_explicit]:
        base.with_vertices(v)  # validates (no degenerate faces)

    # 1. fast path, with and without the shape checks, between two measurements of the dense-product rate
    rates = [dense_rate()]
    fast, unchecked = {}, {}
    for key, wanted in (("all", KINDS), *((kind, (kind,)) for kind in KINDS)):
        fast[key] = time_fast(base_basis, shapes[:n_shapes], wanted, args.repeats, args.batch_size)
        unchecked[key] = time_fast(base_basis, shapes[:n_shapes], wanted, args.repeats, args.batch_size, checked=False)
    rates.append(dense_rate())
    rate = max(rates)
    n_edges = len(opnet.mesh.unique_edges(base.faces))
    flops = {key: fast_path_flops(base.n_vertices, n_edges, args.k, KINDS if key == "all" else (key,)) for key in fast}
    D_fast = opnet.shape_differences(base_basis, shapes[:n_explicit], channels=KINDS, progress=False)
    D_unchecked = fast_path(base_basis, shapes[:n_explicit], opnet.inner_products.get_inner_products(KINDS))

    # 2. explicit formula
    D_exp, fmaps, exp_all, stages = time_explicit(base_basis, base, shapes[:n_explicit])
    shared = stages["eigendecomposition"] + stages["fmap"]
    exp = {"all": exp_all, **{kind: shared + stages[kind] for kind in KINDS}}

    # 3. rows
    rows = []
    label = {"all": " + ".join(KINDS)}
    label.update({k: k for k in KINDS})
    for method, times, D in (
        ("opnet fast path `shape_differences`", fast, D_fast),
        ("the same without the shape checks (`with_channels`)", unchecked, D_unchecked),
    ):
        for key in ("all", *KINDS):
            sl = slice(None) if key == "all" else KINDS.index(key)
            rows.append(
                {
                    "method": method,
                    "operators": label[key],
                    "s_per_shape": times[key],
                    "speedup": exp[key] / times[key],
                    "max_rel_diff": rel_diff(D[:, sl], D_exp[:, sl]),
                    "share_of_dense_rate": flops[key] / times[key] / (rate * 1e9),
                }
            )
    for key in ("all", *KINDS):
        rows.append(
            {
                "method": "explicit: full eigh + `identity_fmap` + `shape_difference`",
                "operators": label[key],
                "s_per_shape": exp[key],
                "speedup": 1.0,
                "max_rel_diff": 0.0,
            }
        )

    # 4. pyFM
    pyfm = {"skipped": pyfm_note}
    if fns is not None:
        per, D_pyfm = time_pyfm(fns, base_basis, fmaps)
        pyfm = {"s_per_shape": per}
        for key, sl, name in (("area", 0, "area"), ("conformal", 1, "conformal")):
            rows.append(
                {
                    "method": f"pyFM `{name}_SD` (C, Λ given)",
                    "operators": name,
                    "s_per_shape": per[key],
                    "speedup": exp[name] / per[key],
                    "max_rel_diff": rel_diff(D_pyfm[:, sl], D_exp[:, KINDS.index(name)]),
                }
            )
        exp_ac = shared + stages["area"] + stages["conformal"]
        for method, seconds in (
            ("pyFM `area_SD` + `conformal_SD` (C, Λ given)", per["both"]),
            ("pyFM `area_SD` + `conformal_SD` + full eigh + C", per["both"] + shared),
        ):
            rows.append(
                {
                    "method": method,
                    "operators": "area + conformal",
                    "s_per_shape": seconds,
                    "speedup": exp_ac / seconds,
                    "max_rel_diff": rel_diff(D_pyfm, D_exp[:, :2]),
                }
            )
    other = monitor.fraction()
    if other is not None:
        info["cpu_used_by_other_processes_during_run"] = f"{100 * other:.0f} %"

    # targets (the public call, checks included)
    speedup_all, rate_all = exp["all"] / fast["all"], 1 / fast["all"]
    share_all = flops["all"] * rate_all / (rate * 1e9)
    targets = {
        "speedup": {"value": speedup_all, "target": TARGET_SPEEDUP, "met": bool(speedup_all >= TARGET_SPEEDUP)},
        "throughput_shapes_per_s": {
            "value": rate_all,
            "target": TARGET_THROUGHPUT,
            "met": bool(rate_all >= TARGET_THROUGHPUT),
        },
        "share_of_dense_rate": {
            "value": share_all,
            "target": TARGET_FRACTION,
            "met": bool(share_all >= TARGET_FRACTION),
        },
    }
    prof = None
    if args.profile or not targets["throughput_shapes_per_s"]["met"]:
        text, prof_rows = profile_fast(base_basis, shapes[:n_shapes], args.batch_size)
        share = {k: fast[k] / sum(fast[q] for q in KINDS) for k in KINDS}
        prof = {"operator_share": share, "top_functions": prof_rows, "text": text}
    return {
        "date": time.strftime("%Y-%m-%d"),
        "config": {
            "mesh": f"toy.capsule({args.preset!r})",
            "n_vertices": base.n_vertices,
            "n_faces": base.n_faces,
            "k": args.k,
            "n_shapes_fast": n_shapes,
            "n_shapes_explicit": n_explicit,
            "batch_size": args.batch_size,
            "repeats": args.repeats,
            "seed": args.seed,
            "quick": args.quick,
        },
        "machine": info,
        "rows": [{**r, "shapes_per_s": 1 / r["s_per_shape"]} for r in rows],
        "dense_rate_gflops": {"before": rates[0], "after": rates[1], "used": rate, "size": DENSE_SIZE},
        "fast_path_mflop_per_shape": {key: flops[key] / 1e6 for key in flops},
        "explicit_stages_s_per_shape": stages,
        "explicit_total_s_per_shape": exp_all,
        "pyfm": pyfm,
        "targets": targets,
        "machine_busy_at_start": busy,
        "loadavg_1min_at_end": round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None,
        "profile": prof,
    }


def report(result: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    c, info, stages = result["config"], result["machine"], result["explicit_stages_s_per_shape"]
    pyfm = result["pyfm"]
    out = [
        f"Base: `{c['mesh']}`, {c['n_vertices']} vertices, {c['n_faces']} faces; base eigenbasis k = {c['k']}; "
        f"fast path on {c['n_shapes_fast']} shapes (batch_size {c['batch_size']}, best of {c['repeats']}), explicit "
        f"formula on {c['n_shapes_explicit']} shapes; seed {c['seed']}{' (--quick)' if c['quick'] else ''}.",
        "",
        markdown_table(result["rows"]),
        "",
        "Explicit formula per shape: "
        + ", ".join(f"{k} {fmt_sec(v)}" for k, v in stages.items())
        + f" (total {fmt_sec(result['explicit_total_s_per_shape'])}).",
        "max rel. diff: the largest over the explicitly timed shapes of ‖D − D_explicit‖_F / ‖D_explicit‖_F; the "
        "explicit per-operator rows are eigendecomposition + fmap + that operator.",
        f"pyFM rows skipped: {pyfm['skipped']}"
        if "skipped" in pyfm
        else "The \"(C, Λ given)\" pyFM rows time only pyFM's last step on the explicit path's functional maps and "
        "eigenvalues, so they are not like-for-like; the last pyFM row adds the measured eigendecomposition and map. "
        "pyFM has no extrinsic shape difference.",
        "",
    ]
    t = result["targets"]
    speedup, rate, share = t["speedup"], t["throughput_shapes_per_s"], t["share_of_dense_rate"]
    dense, mflop = result["dense_rate_gflops"], result["fast_path_mflop_per_shape"]
    verdict = {True: "met", False: "**missed**"}
    out += [
        f"The machine's dense-product rate, measured in this run: {dense['before']:.1f} GFLOP/s before the fast path "
        f"and {dense['after']:.1f} after (numpy's float64 product of two {dense['size']} × {dense['size']} "
        f"matrices, best of 3); the share column is the fast path's matrix-product work "
        f"({mflop['all']:.1f} MFLOP a shape for the three operators: "
        + ", ".join(f"{k} {mflop[k]:.1f}" for k in KINDS)
        + f") at its measured speed, over the larger rate ({dense['used']:.1f} GFLOP/s). The per-face arithmetic "
        "(areas, cotangents) is not counted in the work: it is what keeps the share below 100 %.",
        "",
        f"- Fast path ≥ {speedup['target']:.0f}× faster than the explicit formula (all three operators): "
        f"{speedup['value']:,.0f}× — {verdict[speedup['met']]}.",
        f"- Fast path ≥ {rate['target']:.0f} shapes/s for all three operators together on {info['cpus_usable']} "
        f"cores (`shape_differences`, checks included): {rate['value']:,.1f} shapes/s — {verdict[rate['met']]}.",
        f"- Fast path ≥ {100 * share['target']:.0f} % of the machine's dense-product rate (the same call): "
        f"{100 * share['value']:.0f} % — {verdict[share['met']]}.",
        "",
        measured(result["date"], info),
    ]
    if result["profile"] is not None:
        share = result["profile"]["operator_share"]
        out += [
            "",
            "Fast-path profile; time share per operator (from the separate timings): "
            + ", ".join(f"{k} {100 * v:.0f} %" for k, v in share.items()),
            "```\n" + result["profile"]["text"].strip() + "\n```",
        ]
    return "\n".join(out)


def main(argv=None):
    args, result = run_benchmark("Shape-difference benchmark", parse_args, measure, report, argv)
    if args.strict and not all(t["met"] for t in result["targets"].values()):
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
