"""Benchmark: the learning-rate schedule and epoch count of the paper's network, chosen on ``val`` with seeds.

The paper's network trained with a constant learning rate (Adam 10⁻³) has a validation error that jumps by tens of
per cent from one epoch to the next until its last one, so which epoch is kept, and the test error, is partly luck.
This trains each candidate (:data:`CANDIDATES`: a schedule and an epoch count, the rest of the preset's budget) with
several seeds through :func:`opnet.train.fit` (Int+Ext, depth 1, the paper's variant) and reports, per candidate,
the best ``val`` d_R of each seed, their mean and spread, and whether each run converged
(:func:`opnet.train.convergence`: its last 10 % of epochs within 5 % of its best). ``test`` is never read.

The rule that chooses (:func:`choose`): among the candidates whose every seed converged, the lowest mean best ``val``
d_R; a candidate of fewer epochs wins when its mean is within the larger of the two seed spreads of that one.

Each run has its own folder under ``--out`` (a second call reuses finished runs; an interrupted one resumes);
``--jobs 2 --threads 1`` trains two networks side by side, one torch thread each (on 2 cores, nearly twice the
throughput of one network on two threads: benchmarks/results/training.json). ``--json PATH`` writes everything
(``benchmarks/results/schedules.json`` at ``--preset default`` is the shipped one, rendered in docs/results.md).

Run::

    .venv/bin/python benchmarks/schedules.py --preset quick --out build/schedules-quick --jobs 2 --threads 1 \\
        --candidates constant-60 onecycle-60 constant-120 onecycle-120 onecycle-120-lr3e-3 onecycle-60-batch8 \\
        --json results/schedules-quick.json
    .venv/bin/python benchmarks/schedules.py --preset quick --out build/schedules-quick --jobs 2 --threads 1 \\
        --candidates onecycle-60-lr3e-3 onecycle-80-lr3e-3 onecycle-120-lr3e-3 --json results/schedules-quick-short.json
    .venv/bin/python benchmarks/schedules.py --preset default --out ~/.cache/opnet/schedules-default --jobs 2 \\
        --threads 1 --candidates constant-60 onecycle-30 onecycle-60 --json results/schedules.json
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context

import numpy as np
from shape_differences import load_span, measured, run_benchmark, torch_machine_info

import opnet

#: name → (schedule, epochs[, overrides]): the candidates (the preset's batch size and peak learning rate unless the
#: overrides set ``lr`` or ``batch_size``).
CANDIDATES = {
    "constant-60": ("constant", 60),
    "onecycle-30": ("onecycle", 30),
    "onecycle-60": ("onecycle", 60),
    # for quick's 296 training shapes, where 60 epochs of batch 16 are about 1100 steps: more steps, a higher peak
    "constant-120": ("constant", 120),
    "onecycle-120": ("onecycle", 120),
    "onecycle-120-lr3e-3": ("onecycle", 120, dict(lr=3e-3)),
    # fewer epochs at that peak: what a notebook's network costs in `make run` (issue 41's 10 minutes)
    "onecycle-60-lr3e-3": ("onecycle", 60, dict(lr=3e-3)),
    "onecycle-80-lr3e-3": ("onecycle", 80, dict(lr=3e-3)),
    "onecycle-60-batch8": ("onecycle", 60, dict(batch_size=8)),
}


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="quick", help="collection and budget preset (quick | default | paper)")
    ap.add_argument("--out", required=True, help="folder for the run directories (reused to resume)")
    ap.add_argument("--candidates", nargs="+", default=list(CANDIDATES), choices=list(CANDIDATES))
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="seeds of every candidate (0 1 2)")
    ap.add_argument("--jobs", type=int, default=1, help="networks trained side by side, each in its own process (1)")
    ap.add_argument("--threads", type=int, default=None, help="torch threads per process (default torch's)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def _train(preset: str, out: str, name: str, seed: int, threads: int | None) -> dict:
    """Train one candidate with one seed (in a worker process); its row."""
    import torch

    from opnet.experiments.plan import BUDGETS

    if threads:
        torch.set_num_threads(threads)
    schedule, epochs, *more = CANDIDATES[name]
    budget = BUDGETS[preset]
    settings = dict(batch_size=budget.batch_size, lr=budget.lr) | (more[0] if more else {})
    coll = opnet.data.load_collection("humans", preset, progress=False)
    _, hist = opnet.train.fit(
        coll,
        epochs=epochs,
        **settings,
        seed=seed,
        schedule=schedule,
        run_dir=f"{out}/{name}-s{seed}",
        progress=False,
    )
    conv = opnet.train.convergence(hist)
    return dict(
        candidate=name,
        schedule=schedule,
        epochs=epochs,
        **settings,
        seed=seed,
        **conv.as_dict(),
        train_s=round(sum(h["seconds"] for h in hist), 1),
        val_curve=[h["val_d_R"] for h in hist],
    )


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""
    from opnet.experiments.plan import BUDGETS
    from opnet.train.curves import TAIL, TOLERANCE

    info = torch_machine_info()
    budget = BUDGETS[args.preset]
    coll = opnet.data.load_collection("humans", args.preset)  # built once, before the workers read it
    jobs = [(n, s) for n in sorted(args.candidates, key=lambda n: -CANDIDATES[n][1]) for s in args.seeds]
    rows = []
    with ProcessPoolExecutor(max_workers=args.jobs, mp_context=get_context("spawn")) as pool:
        futures = [pool.submit(_train, args.preset, args.out, n, s, args.threads) for n, s in jobs]
        for done in as_completed(futures):
            row = done.result()
            rows.append(row)
            print(
                f"{row['candidate']} seed {row['seed']}: best val {row['best_val'] * 1e4:.3f}e-4 at epoch "
                f"{row['best_epoch']}, tail ratio {row['tail_ratio']:.3f}, {row['train_s']:.0f} s",
                flush=True,
            )
    rows.sort(key=lambda r: (list(CANDIDATES).index(r["candidate"]), r["seed"]))
    return {
        "date": time.strftime("%Y-%m-%d"),
        "config": {
            "preset": args.preset,
            "train_shapes": len(coll.indices("train")),
            "val_shapes": len(coll.indices("val")),
            "batch_size": budget.batch_size,
            "lr": budget.lr,
            "seeds": list(args.seeds),
            "channels": "A+E+C",
            "depth": 1,
            "variant": "paper",
            "jobs": args.jobs,
            "threads": args.threads,
            "tail": TAIL,
            "tolerance": TOLERANCE,
        },
        "machine": info | {"loadavg_1min_at_end": round(os.getloadavg()[0], 2)},
        "rows": rows,
    }


def summary(rows: list[dict]) -> dict:
    """candidate → its seeds' best val d_R: ``mean``, ``std`` (over seeds), ``converged`` (every seed), ``seconds``."""
    out = {}
    for name in dict.fromkeys(r["candidate"] for r in rows):
        mine = [r for r in rows if r["candidate"] == name]
        vals = np.array([r["best_val"] for r in mine])
        out[name] = dict(
            mean=float(vals.mean()),
            std=float(vals.std(ddof=1)) if len(vals) > 1 else None,
            min=float(vals.min()),
            max=float(vals.max()),
            converged=all(r["converged"] for r in mine),
            n_converged=sum(r["converged"] for r in mine),
            seeds=len(mine),
            epochs=mine[0]["epochs"],
            schedule=mine[0]["schedule"],
            lr=mine[0].get("lr"),
            batch_size=mine[0].get("batch_size"),
            seconds=float(np.mean([r["train_s"] for r in mine])),
            tail=(min(r["tail_ratio"] for r in mine), max(r["tail_ratio"] for r in mine)),
        )
    return out


def choose(rows: list[dict]) -> str | None:
    """The candidate the rule picks (the module's docstring), or ``None`` when none converged on every seed."""
    s = summary(rows)
    ok = [n for n, v in s.items() if v["converged"]]
    if not ok:
        return None
    best = min(ok, key=lambda n: s[n]["mean"])
    for n in sorted(ok, key=lambda n: s[n]["epochs"]):
        if s[n]["epochs"] >= s[best]["epochs"]:
            break
        spread = max(s[n]["std"] or 0.0, s[best]["std"] or 0.0)
        if s[n]["mean"] <= s[best]["mean"] + spread:
            return n
    return best


def report(result: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    c, m, rows = result["config"], result["machine"], result["rows"]
    s = summary(rows)
    out = [
        f"humans at `{c['preset']}` ({c['train_shapes']} `train`, {c['val_shapes']} `val` shapes), the paper's "
        f"network (Int+Ext, depth {c['depth']}), batch {c['batch_size']} and peak lr {c['lr']:g} unless the candidate "
        f"sets them, seeds "
        f"{', '.join(map(str, c['seeds']))}: best `val` d_R ×10⁻⁴ (mean ± standard deviation over seeds, and the "
        "range), how many seeds converged (last 10 % of the epochs within 5 % of the run's best), the worst of those "
        "epochs over the run's best (the range over seeds), and the mean training time per seed.",
        "",
        "| candidate | schedule | epochs | peak lr | batch | best val d_R | range | converged | last 10 % / best | "
        "train s |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, v in s.items():
        std = "" if v["std"] is None else f" ± {1e4 * v['std']:.3f}"
        lr, batch = v["lr"] or c["lr"], v["batch_size"] or c["batch_size"]  # older files: the preset's
        out.append(
            f"| {name} | {v['schedule']} | {v['epochs']} | {lr:g} | {batch} | {1e4 * v['mean']:.3f}{std} | "
            f"{1e4 * v['min']:.3f}–{1e4 * v['max']:.3f} | {v['n_converged']}/{v['seeds']} | "
            f"{v['tail'][0]:.2f}–{v['tail'][1]:.2f} | {v['seconds']:.0f} |"
        )
    chosen = choose(rows)
    out += ["", f"Chosen by the rule: **{chosen}**." if chosen else "No candidate converged on every seed."]
    out += [
        "",
        f"Training times are wall time ({c['jobs']} network(s) side by side, {c['threads'] or 'default'} torch "
        f"thread(s) each; {load_span(m)}). " + measured(result["date"], m),
    ]
    return "\n".join(out)


def main(argv=None):
    run_benchmark("Learning-rate schedules of the paper's network on val", parse_args, measure, report, argv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
