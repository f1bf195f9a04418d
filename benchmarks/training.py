"""Benchmark: OperatorNet training throughput (samples/s).

Times full training steps (forward, Kabsch-aligned loss, backward, Adam) of the paper's network (depth 1, three
60 × 60 operators in, 1229 vertices out: the humans' size) on synthetic tensors, at several batch sizes and thread
counts, on the CPU and on CUDA when present, with torch's default Adam and with the fused one that
``opnet.train.fit`` uses (``opnet.train.loop.adam``), side by side. Best of 3 repeats after a warm-up. ``--json
PATH`` writes the results (``benchmarks/results/training.json`` is the shipped one).

The input scaling ``D`` against ``D − I`` on ``val`` (which trains networks on the humans) has its own script and
result file, ``benchmarks/scaling.py`` (``results/scaling.json``); ``training.py --scaling [its options]`` runs it
(``--scaling-batch-size`` is its ``--batch-size``).

Run::

    .venv/bin/python benchmarks/training.py                      # throughput table, ~2 min
    .venv/bin/python benchmarks/training.py --scaling --preset quick --epochs 80 --seeds 0 1 2 3
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import numpy as np
import torch
from shape_differences import measured, save

import opnet
from opnet.train.loop import adam

OPTIMIZERS = {"torch default": lambda params: torch.optim.Adam(params, 1e-3), "fused (fit's)": lambda p: adam(p, 1e-3)}


def throughput(device: str, batch_sizes, threads, steps: int, n_vertices: int = 1229, k: int = 60) -> list[dict]:
    rows = []
    for t in threads:
        torch.set_num_threads(t)
        for bs in batch_sizes:
            for name, make in OPTIMIZERS.items():
                g = torch.Generator().manual_seed(0)
                x = (torch.eye(k) + 0.05 * torch.randn(bs, 3, k, k, generator=g)).to(device)
                y = torch.randn(bs, n_vertices, 3, generator=g).to(device)
                net = opnet.OperatorNet(n_vertices, k).to(device)
                opt = make(net.parameters())

                def step():
                    opt.zero_grad()
                    opnet.rigid_alignment_loss(net(x), y).backward()
                    opt.step()

                step()
                best = np.inf
                for _ in range(3):
                    if device == "cuda":
                        torch.cuda.synchronize()
                    t0 = time.perf_counter()
                    for _ in range(steps):
                        step()
                    if device == "cuda":
                        torch.cuda.synchronize()
                    best = min(best, time.perf_counter() - t0)
                rows.append(
                    dict(
                        device=device,
                        threads=t if device == "cpu" else None,
                        batch=bs,
                        optimizer=name,
                        samples_per_s=bs * steps / best,
                        ms_per_step=1e3 * best / steps,
                    )
                )
    return rows


def report(result: dict) -> str:
    """The Markdown report (what the script prints; the docs render the shipped result)."""
    rows = result["rows"]
    plain = {(r["device"], r["threads"], r["batch"]): r for r in rows if r["optimizer"] == "torch default"}
    out = [
        f"The paper's network (depth 1, three {result['k']} × {result['k']} operators in, {result['n_vertices']} "
        f"vertices out), full training steps on synthetic tensors, best of 3 × {result['steps']} steps after a "
        "warm-up; the last column is the fused Adam's speed over torch's default in the same run.",
        "",
        "| device | threads | batch | Adam | samples/s | ms/step | vs default |",
        "|---|---:|---:|---|---:|---:|---:|",
    ]
    for r in rows:
        ref = plain[r["device"], r["threads"], r["batch"]]
        out.append(
            f"| {r['device']} | {r['threads'] or '–'} | {r['batch']} | {r['optimizer']} | {r['samples_per_s']:,.0f} "
            f"| {r['ms_per_step']:.1f} | {ref['ms_per_step'] / r['ms_per_step']:.2f}× |"
        )
    m = result["machine"]
    out += ["", measured(result["date"], m)]
    return "\n".join(out)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if "--scaling" in argv:  # the input scaling: benchmarks/scaling.py, its own report and result file
        import scaling

        rest = [a for a in argv if a != "--scaling"]
        return scaling.main(["--batch-size" if a == "--scaling-batch-size" else a for a in rest])
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--batch-sizes", type=int, nargs="+", default=[16, 32, 64])
    p.add_argument("--threads", type=int, nargs="+", default=sorted({1, os.cpu_count() or 1}))
    p.add_argument("--steps", type=int, default=10, help="training steps per timing")
    p.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    p.add_argument("--scaling", action="store_true", help="instead: D against D − I on val (benchmarks/scaling.py)")
    args = p.parse_args(argv)
    machine = dict(processor=platform.processor() or platform.machine(), cpu_count=os.cpu_count())
    machine |= dict(torch=torch.__version__, loadavg_1min_at_start=round(os.getloadavg()[0], 2))
    rows = throughput("cpu", args.batch_sizes, args.threads, args.steps)
    if torch.cuda.is_available():
        rows += throughput("cuda", args.batch_sizes + [128, 256], [1], 50)
        machine["gpu"] = torch.cuda.get_device_name()
    machine["loadavg_1min_at_end"] = round(os.getloadavg()[0], 2)
    result = dict(date=time.strftime("%Y-%m-%d"), n_vertices=1229, k=60, steps=args.steps, machine=machine, rows=rows)
    print(report(result))
    if args.json:
        save(result, args.json)


if __name__ == "__main__":
    main()
