"""Benchmark: OperatorNet's input scaling, ``D`` against ``D − I``, on ``val``.

Trains the paper's network (depth 1, Int+Ext) on the humans of a preset twice per seed through
:func:`opnet.train.fit`, once fed ``D`` and once ``D − I`` (``subtract_identity``), with the same data, seed,
epochs and batches, and reports the best validation ``d_R`` of each, their ratio and how many seeds each input
wins: the measurement behind ``OperatorNet``'s default (``D − I``). It reads only ``train`` and ``val``.
``--json PATH`` writes the results (``benchmarks/results/scaling.json`` is the shipped one, rendered in
docs/results.md, section "Input scaling"). ``benchmarks/training.py --scaling ...`` runs this script.

Run::

    .venv/bin/python benchmarks/scaling.py --preset quick --epochs 80 --seeds 0 1 2 3   # 8 networks
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from shape_differences import load_span, measured, run_benchmark, torch_machine_info

import opnet


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--preset", default="quick", help="collection preset (quick | default | paper)")
    p.add_argument("--epochs", type=int, default=80)
    p.add_argument("--batch-size", type=int, default=16)
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    p.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return p.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""

    info = torch_machine_info()
    ds = opnet.data.load_collection("humans", args.preset)
    rows = []
    for seed in args.seeds:
        row = {"seed": seed}
        for key, sub in (("D", False), ("D_minus_I", True)):
            _, h = opnet.train.fit(
                ds, epochs=args.epochs, batch_size=args.batch_size, seed=seed, subtract_identity=sub, progress=False
            )
            best = min(h, key=lambda e: e["val_d_R"])
            row[key] = {
                "best_val_d_R": best["val_d_R"],
                "epoch": best["epoch"],
                "seconds": sum(e["seconds"] for e in h),
            }
        rows.append(row)
        print(f"seed {seed}: done", flush=True)
    return {
        "date": time.strftime("%Y-%m-%d"),
        "config": {
            "preset": args.preset,
            "train_shapes": len(ds.indices("train")),
            "val_shapes": len(ds.indices("val")),
            "epochs": args.epochs,
            "batch_size": args.batch_size,
            "seeds": list(args.seeds),
        },
        "machine": info | {"loadavg_1min_at_end": round(os.getloadavg()[0], 2)},
        "rows": rows,
    }


def _g(x: float) -> str:
    """Three significant digits, trailing zeros kept (``5.30``)."""
    return f"{x:#.3g}".rstrip(".")


def report(result: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    c, m, rows = result["config"], result["machine"], result["rows"]
    d = np.array([r["D"]["best_val_d_R"] for r in rows]) * 1e4
    dmi = np.array([r["D_minus_I"]["best_val_d_R"] for r in rows]) * 1e4
    out = [
        f"humans at `{c['preset']}` ({c['train_shapes']} `train`, {c['val_shapes']} `val` shapes), the paper's network "
        f"(depth 1, Int+Ext), {c['epochs']} epochs, batch {c['batch_size']}, one run per input and seed: best `val` "
        "d_R ×10⁻⁴.",
        "",
        "| seed | D | D − I | ratio D / (D − I) |",
        "|---:|---:|---:|---:|",
    ]
    for r, a, b in zip(rows, d, dmi):
        out.append(f"| {r['seed']} | {_g(a)} | {_g(b)} | {a / b:.2f} |")
    mean_d, mean_dmi = d.mean(), dmi.mean()
    win = "D − I" if mean_dmi < mean_d else "D"
    out.append(f"| mean | {_g(mean_d)} | {_g(mean_dmi)} | {mean_d / mean_dmi:.2f} |")
    gain = abs(1 - min(mean_d, mean_dmi) / max(mean_d, mean_dmi))
    wins = int(np.sum(dmi < d)) if win == "D − I" else int(np.sum(d < dmi))
    spread = max(d.std(ddof=1), dmi.std(ddof=1)) if len(rows) > 1 else float("nan")
    within = "within" if abs(mean_d - mean_dmi) <= spread else "larger than"
    out += [
        "",
        f"- `{win}` is {100 * gain:.0f} % better on average and better in {wins} of {len(rows)} seeds.",
        f"- The means differ by {abs(mean_d - mean_dmi):.2g} ×10⁻⁴; the seed-to-seed standard deviation of one input "
        f"is up to {spread:.2g} ×10⁻⁴ (the difference is {within} it).",
        "",
        f"The errors do not depend on the machine's load ({load_span(m)}); the training times in the JSON do. "
        + measured(result["date"], m),
    ]
    return "\n".join(out)


def main(argv=None):
    run_benchmark("Input scaling: D against D − I", parse_args, measure, report, argv)
    return 0


if __name__ == "__main__":
    main()
