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
import platform
import sys

import numpy as np
import torch
from shape_differences import OtherLoad, best_of, make_shapes

import opnet
from opnet.data import toy
from opnet.torch_ops import ShapeDifferences


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer shapes and repeats (smoke run)")
    ap.add_argument("--n-shapes", type=int, default=256, help="shapes per timed call (default 256)")
    ap.add_argument("--batch-size", type=int, default=64, help="shapes per torch call (default 64)")
    ap.add_argument("--k", type=int, default=60, help="base eigenbasis size (default 60)")
    ap.add_argument("--repeats", type=int, default=3, help="repeats; the best is kept (default 3)")
    args = ap.parse_args(argv)
    n = 64 if args.quick else args.n_shapes
    repeats = 1 if args.quick else args.repeats
    monitor = OtherLoad()
    base = toy.capsule("default")
    basis = opnet.eigenbasis(base, args.k)
    shapes = make_shapes(base, n, seed=0)
    ref = opnet.shape_differences(basis, shapes, progress=False)
    rows = []

    def numpy_run():
        opnet.shape_differences(basis, shapes, batch_size=args.batch_size, progress=False)

    numpy_run()
    t_np = best_of(numpy_run, repeats) / n
    rows.append(("numpy fast path `shape_differences`", "cpu", "float64", "forward", t_np))
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
                rows.append(
                    ("torch_ops `ShapeDifferences`", dev, str(dtype).split(".")[1], mode, best_of(run, repeats) / n)
                )
            if dev == "cpu" and dtype == torch.float64:
                with torch.no_grad():
                    out = module(X).numpy()
                err = float(np.max(np.linalg.norm(out - ref, axis=(-2, -1)) / np.linalg.norm(ref, axis=(-2, -1))))

    print(f"# Differentiable shape differences{' (--quick)' if args.quick else ''}\n")
    print(
        f"toy.capsule('default'): {base.n_vertices} vertices, k = {args.k}, {n} shapes, batch {args.batch_size}, "
        f"best of {repeats}; all three operators together.\n"
    )
    print("| method | device | dtype | pass | shapes/s | ratio to numpy forward |")
    print("|---|---|---|---|---:|---:|")
    for name, dev, dt, mode, t in rows:
        print(f"| {name} | {dev} | {dt} | {mode} | {1 / t:,.0f} | {t_np / t:.2f}× |")
    print(f"\nlargest relative difference of torch float64 from numpy (‖ΔD‖_F / ‖D‖_F): {err:.1e}")
    gpu = f"; GPU {torch.cuda.get_device_name()}" if torch.cuda.is_available() else ""
    print(
        f"machine: {platform.processor() or platform.machine()}, torch {torch.__version__}, "
        f"{torch.get_num_threads()} torch threads{gpu}"
    )
    other = monitor.fraction()
    if other is not None and other > 0.1:
        print(f"WARNING: other processes used {100 * other:.0f} % of the CPUs during the run; timings are pessimistic.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
