"""Benchmark: differentiable shape differences (``opnet.torch_ops``) beside the numpy fast path.

On the same shapes as ``shape_differences.py`` (the ~1000-vertex toy capsule, k = 60, seeded bends and
bulges), measured side by side in one run, best of ``--repeats`` after a warm-up:

1. numpy fast path ``opnet.shape_differences`` (float64) — the reference;
2. ``opnet.torch_ops.ShapeDifferences`` forward, float64 and float32, on the CPU (``torch`` threads as set);
3. the same, forward + backward (the gradient of the summed operators with respect to the vertices), which
   is what one step of :func:`opnet.reconstruct.reconstruct` costs;
4. the same on CUDA when a GPU is present (synchronised timings).

Prints a Markdown table (shapes/s and the ratio to the numpy fast path) and the largest relative difference
of the torch float64 operators from numpy's.

Run::

    .venv/bin/python benchmarks/torch_ops.py              # ~30 s on 2 idle cores
    .venv/bin/python benchmarks/torch_ops.py --quick
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
import torch
from shape_differences import OtherLoad, best_of, machine_info, make_shapes, measured, run_benchmark

import opnet
from opnet.data import toy
from opnet.torch_ops import ShapeDifferences


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer shapes and repeats (smoke run)")
    ap.add_argument("--n-shapes", type=int, default=256, help="shapes per timed call (default 256)")
    ap.add_argument("--batch-size", type=int, default=64, help="shapes per torch call (default 64)")
    ap.add_argument("--k", type=int, default=60, help="base eigenbasis size (default 60)")
    ap.add_argument("--repeats", type=int, default=3, help="repeats; the best is kept (default 3)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""
    n = 64 if args.quick else args.n_shapes
    repeats = 1 if args.quick else args.repeats
    info = machine_info(None)
    info.pop("pyfmaps")
    monitor = OtherLoad()
    base = toy.capsule("default")
    basis = opnet.eigenbasis(base, args.k)
    shapes = make_shapes(base, n, seed=0)
    ref = opnet.shape_differences(basis, shapes, progress=False)

    def numpy_run():
        opnet.shape_differences(basis, shapes, batch_size=args.batch_size, progress=False)

    numpy_run()
    t_np = best_of(numpy_run, repeats) / n
    rows = [
        dict(
            method="numpy fast path `shape_differences`",
            device="cpu",
            dtype="float64",
            mode="forward",
            s_per_shape=t_np,
        )
    ]
    devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
    err = None
    for dev in devices:
        for dtype in (torch.float64, torch.float32):
            module = ShapeDifferences(basis, device=dev)
            X = torch.tensor(shapes, dtype=dtype, device=dev)
            for mode in ("forward", "forward + backward"):

                def run():
                    for s in range(0, n, args.batch_size):
                        if mode == "forward":
                            with torch.no_grad():
                                module(X[s : s + args.batch_size])
                        else:
                            x = X[s : s + args.batch_size].clone().requires_grad_(True)
                            module(x).sum().backward()
                    if dev == "cuda":
                        torch.cuda.synchronize()

                run()
                name = str(dtype).split(".")[1]
                seconds = best_of(run, repeats) / n
                rows.append(
                    dict(method="torch_ops `ShapeDifferences`", device=dev, dtype=name, mode=mode, s_per_shape=seconds)
                )
            if dev == "cpu" and dtype == torch.float64:
                with torch.no_grad():
                    out = module(X).numpy()
                err = float(np.max(np.linalg.norm(out - ref, axis=(-2, -1)) / np.linalg.norm(ref, axis=(-2, -1))))
    other = monitor.fraction()
    if other is not None:
        info["cpu_used_by_other_processes_during_run"] = f"{100 * other:.0f} %"
    info |= dict(torch=torch.__version__, torch_threads=torch.get_num_threads())
    if torch.cuda.is_available():
        info["gpu"] = torch.cuda.get_device_name()
    rows = [dict(r, shapes_per_s=1 / r["s_per_shape"], ratio_to_numpy=t_np / r["s_per_shape"]) for r in rows]
    config = dict(mesh="toy.capsule('default')", n_vertices=base.n_vertices, k=args.k, n_shapes=n)
    config |= dict(batch_size=args.batch_size, repeats=repeats, quick=args.quick)
    return dict(date=time.strftime("%Y-%m-%d"), config=config, machine=info, rows=rows, max_rel_diff_float64=err)


def report(result: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    c = result["config"]
    out = [
        f"`{c['mesh']}`: {c['n_vertices']} vertices, k = {c['k']}, {c['n_shapes']} shapes in batches of "
        f"{c['batch_size']}, best of {c['repeats']}; all three operators together"
        f"{' (--quick)' if c['quick'] else ''}.",
        "",
        "| method | device | dtype | pass | shapes/s | ratio to numpy forward |",
        "|---|---|---|---|---:|---:|",
    ]
    out += [
        f"| {r['method']} | {r['device']} | {r['dtype']} | {r['mode']} | {r['shapes_per_s']:,.0f} | "
        f"{r['ratio_to_numpy']:.2f}× |"
        for r in result["rows"]
    ]
    out += [
        "",
        "Largest relative difference of the torch float64 operators from numpy's (‖ΔD‖_F / ‖D‖_F): "
        f"{result['max_rel_diff_float64']:.1e}.",
        "",
        measured(result["date"], result["machine"]),
    ]
    return "\n".join(out)


def main(argv=None):
    run_benchmark("Differentiable shape differences", parse_args, measure, report, argv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
