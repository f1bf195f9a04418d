"""Benchmark: the data pipeline on a Dask cluster against the same work on one machine.

Side by side in one run, on the quick humans (read or built beforehand, not counted) and the same cores: the
computed maps of ``--shapes`` shapes from their 2k meshes (``opnet.data.mapped_collection``, the pipeline's
longest step: 78 minutes for the ``default`` humans on 2 cores) and a channel of one's own without
``project_batch`` over every shape (``Collection.with_channels``, shape by shape), each after a warm-up call (the 2k
body model, the processes' imports), each

- on one machine: joblib's local processes (``n_jobs=-1``), and
- on a ``dask.distributed.LocalCluster`` of as many single-threaded worker processes, through joblib's Dask backend
  (``with joblib.parallel_config(backend="dask"):``, the code a cluster user runs; the cluster is started
  beforehand, not counted).

Both give the same operators (checked); the ratio is what the Dask scheduler costs over joblib's processes on
one machine. On a real cluster the workers are other machines and the time falls with their number.

Run::

    .venv/bin/python benchmarks/cluster.py --shapes 16 --json results/cluster.json
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
import time

import numpy as np
from shape_differences import load_span, run_benchmark

import opnet
from opnet.data import mapped_collection


class ShapeByShapeArea(opnet.InnerProduct):
    """The area inner product without ``project_batch``: ``with_channels`` computes it shape by shape in processes."""

    name = "area shape by shape"

    def project(self, vertices, faces, evecs):
        return opnet.inner_products.AreaInnerProduct().project(vertices, faces, evecs)


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shapes", type=int, default=16, help="shapes whose maps are computed (16)")
    ap.add_argument("--workers", type=int, default=None, help="processes and Dask workers (default: the cores)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def measure(args) -> dict:
    import cloudpickle
    import distributed
    import joblib

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import this script
    workers = args.workers or opnet._parallel.usable_cores()
    humans = opnet.data.load_collection("humans", "quick", progress=False)
    idx = np.linspace(0, len(humans) - 1, args.shapes).round().astype(int)
    few = humans.subset(np.unique(idx))
    result = {"date": time.strftime("%Y-%m-%d"), "shapes": len(few), "channel_shapes": len(humans)}
    result |= {"workers": workers, "cpu_count": os.cpu_count()}
    result["loadavg_1min_at_start"] = round(os.getloadavg()[0], 2)
    chunk = max(1, len(few) // (2 * workers))  # two parts per worker: the same tasks for both
    cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None)
    with cluster, distributed.Client(cluster), tempfile.TemporaryDirectory() as root:
        timings, ops = {}, {}
        for where in ("local", "dask"):
            with joblib.parallel_config(backend="dask") if where == "dask" else contextlib.nullcontext():
                # warm-up, not counted: the 2k body model, the local processes' imports, the channel's first call
                mapped_collection(few.subset([0, 1]), "2k", root=f"{root}/warm-{where}", chunk=1, progress=False)
                humans.subset([0, 1]).with_channels([ShapeByShapeArea()], recompute=True, progress=False)
                t = time.perf_counter()
                maps = mapped_collection(few, "2k", root=f"{root}/{where}", chunk=chunk, progress=False)
                timings[f"maps_{where}_s"] = round(time.perf_counter() - t, 2)
                t = time.perf_counter()
                more = humans.with_channels([ShapeByShapeArea()], recompute=True, progress=False)
                timings[f"channel_{where}_s"] = round(time.perf_counter() - t, 2)
            ops[where] = (maps.operators, more.operators)
    result |= timings
    result["equal"] = all(np.array_equal(a, b) for a, b in zip(ops["local"], ops["dask"]))
    result["loadavg_1min_at_end"] = round(os.getloadavg()[0], 2)
    return result


def report(r: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    rows = [
        (f"computed maps from 2k meshes (`mapped_collection`), {r['shapes']} shapes", "maps"),
        (f"a channel without `project_batch` (`with_channels`), {r['channel_shapes']} shapes", "channel"),
    ]
    lines = [
        f"Quick humans; {r['workers']} local processes against a Dask `LocalCluster` of {r['workers']} "
        f"single-threaded workers on the same {r['cpu_count']} cores, each step after a warm-up call ({load_span(r)}; "
        f"measured {r['date']}).",
        "",
        "| step | joblib, local processes (s) | Dask cluster (s) | Dask / local |",
        "|---|---:|---:|---:|",
    ]
    for label, key in rows:
        local, dask = r[f"{key}_local_s"], r[f"{key}_dask_s"]
        lines.append(f"| {label} | {local:.1f} | {dask:.1f} | {dask / local:.2f} |")
    lines += ["", f"Same operators on both: {'yes' if r['equal'] else 'NO'}."]
    return "\n".join(lines)


if __name__ == "__main__":
    run_benchmark("The data pipeline on a Dask cluster", parse_args, measure, report)
