"""Benchmark: what makes refinement by operator matching (``opnet.reconstruct``) lower d_R, measured on ``val``.

Takes a trained OperatorNet (default: the Int+Ext network that ``python -m opnet reproduce --preset P --out DIR``
trained, ``DIR/runs/table1-A+E+C-d1``), decodes every ``--every``-th ``val`` shape, and runs
:func:`opnet.reconstruct` from the decoded shapes (and from the base) with each setting of a grid: optimiser,
operators matched, smoothness weight and number of steps. It prints the mean ``d_R`` (×10⁻⁴) after 0, 10, 30,
100, 300, 1000 steps (as far as each setting goes), the final relative operator mismatch and the seconds per
shape; then coarse-to-fine schedules over ``k`` (the leading ``m × m`` operators first). ``test`` is never read.
The refinement table of docs/results.md was measured at ``--preset default --every 4``.

Run::

    .venv/bin/python benchmarks/refinement.py --preset default --reproduce-dir build/reproduce-default --every 4
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import opnet
from opnet.evaluate import predict
from opnet.geometric import truncate_operators
from opnet.reproduce import run_path

AE = ("area", "extrinsic")
#: (start, optimiser, operators, smoothness, steps, extra options)
GRID = [
    ("network", "adam", opnet.KINDS, 0.0, 100, dict(lr=1e-4)),
    ("network", "lbfgs", opnet.KINDS, 0.0, 100, {}),
    ("network", "lbfgs", opnet.KINDS, 0.01, 100, {}),
    ("network", "lbfgs", opnet.KINDS, 0.1, 300, {}),
    ("network", "lbfgs", opnet.KINDS, 1.0, 100, {}),
    ("network", "lbfgs", opnet.KINDS, 10.0, 100, {}),
    ("network", "lbfgs", AE, 0.1, 100, {}),
    ("network", "lbfgs", AE, 1.0, 1000, {}),
    ("network", "lbfgs", AE, 10.0, 300, {}),
    ("base", "lbfgs", opnet.KINDS, 0.0, 100, {}),
    ("base", "lbfgs", opnet.KINDS, 1.0, 300, {}),
]
SHOWN = (0, 10, 30, 100, 300, 1000)
#: coarse-to-fine schedules over k: (k, steps) stages, area + extrinsic, smoothness 1
COARSE_TO_FINE = [[(20, 100), (40, 100), (60, 100)], [(10, 50), (20, 50), (30, 50), (45, 50), (60, 100)]]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection preset (quick | default | paper)")
    ap.add_argument(
        "--reproduce-dir",
        help="the reproduce output whose Int+Ext network is refined "
        "(default: opnet.data.default_root()/reproduce-<preset>)",
    )
    ap.add_argument("--every", type=int, default=4, help="use every N-th val shape (default 4)")
    ap.add_argument("--quick", action="store_true", help="only the first two settings, at most 30 steps")
    args = ap.parse_args(argv)
    coll = opnet.data.load_collection("humans", args.preset)
    out = args.reproduce_dir or opnet.data.default_root() / f"reproduce-{args.preset}"
    net = opnet.train.load_model(run_path(out, "table1", opnet.KINDS, 1), coll)
    idx = coll.indices("val")[:: args.every]
    gt = coll.vertices[idx].astype(np.float64)
    decoded = predict(net, coll.operators[idx])
    grid = [(*g[:4], min(g[4], 30), g[5]) for g in GRID[:2]] if args.quick else GRID
    print(f"# Refinement on val · preset {args.preset}, {len(idx)} shapes\n")
    print(
        "| start | optimiser | operators | smoothness | "
        + " | ".join(str(s) for s in SHOWN)
        + " | final mismatch | s/shape |"
    )
    print("|---|---|---|---:|" + "---:|" * (len(SHOWN) + 2))
    for start, optimizer, channels, smoothness, steps, extra in grid:
        curve = {}

        def record(step, X, mismatch):
            if step in SHOWN or step == steps:
                curve[step] = (float(opnet.d_R(gt, X.numpy()).mean()), float(mismatch.mean()))

        chans = [opnet.KINDS.index(c) for c in channels]
        t = time.perf_counter()
        opnet.reconstruct(
            coll.operators[idx][:, chans],
            coll.base_basis,
            init=decoded if start == "network" else "base",
            channels=channels,
            steps=steps,
            optimizer=optimizer,
            smoothness=smoothness,
            callback=record,
            progress=False,
            **extra,
        )
        seconds = (time.perf_counter() - t) / len(idx)
        cells = [f"{1e4 * curve[s][0]:.3f}" if s in curve else "" for s in SHOWN]
        label = "A+E+C" if channels == opnet.KINDS else "A+E"
        print(
            f"| {start} | {optimizer} | {label} | {smoothness:g} | "
            + " | ".join(cells)
            + f" | {curve[max(curve)][1]:.2g} | {seconds:.2f} |",
            flush=True,
        )
    if not args.quick:
        print("\n| coarse-to-fine stages (k: steps) | d_R after each stage | s/shape |\n|---|---|---:|")
        D = coll.operators[idx][:, [opnet.KINDS.index(c) for c in AE]].astype(np.float64)
        for schedule in COARSE_TO_FINE:
            X, t, after = decoded, time.perf_counter(), []
            for m, steps in schedule:
                X = opnet.reconstruct(
                    truncate_operators(D, coll.base_basis, AE, m),
                    coll.base_basis.truncate(m),
                    init=X,
                    channels=AE,
                    steps=steps,
                    smoothness=1.0,
                    progress=False,
                )
                after.append(f"{1e4 * opnet.d_R(gt, X).mean():.3f}")
            seconds = (time.perf_counter() - t) / len(idx)
            print(
                f"| {', '.join(f'{m}: {n}' for m, n in schedule)} | {' → '.join(after)} | {seconds:.2f} |", flush=True
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
