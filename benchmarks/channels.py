"""Benchmark: adding a channel of one's own to a collection (``Collection.with_channels``).

Times, on the humans collection of a preset (built or read from ``$OPNET_DATA_DIR``, not counted):

- a new channel with a batched ``project_batch`` over every shape: the first call (computed and cached beside the
  collection) and the second (read back from the cache);
- a channel with ``project`` only (shape by shape) on ``--shapes`` shapes, in this process and in processes
  (``n_jobs=-1``), side by side in one run: the ratio is what the processes buy on this machine;
- the built-in area channel through the same batched path, as the reference;
- FuncChar's two built-in offset channels (``offset_area``, ``offset_conformal``) over every shape, computed anew.

Run::

    .venv/bin/python benchmarks/channels.py                    # the default humans (5856 shapes)
    .venv/bin/python benchmarks/channels.py --preset quick
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from shape_differences import run_benchmark

import opnet


class RadialArea(opnet.InnerProduct):
    """``M = diag(a_i |v_i − c|²)`` (``c`` the area-weighted centroid), written once for one shape or a batch."""

    name = "bench radial area"

    def project(self, vertices, faces, evecs):
        a = opnet.vertex_areas(vertices, faces)
        c = (a[..., None] * vertices).sum(-2)[..., None, :] / a.sum(-1)[..., None, None]
        w = a * ((vertices - c) ** 2).sum(-1)
        return np.einsum("pi,...p,pj->...ij", evecs, w, evecs)

    project_batch = project


class RadialAreaOneByOne(RadialArea):
    """The same channel without a batched form: computed shape by shape."""

    name = "bench radial area one by one"
    project_batch = opnet.InnerProduct.project_batch


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--preset", default="default", choices=list(opnet.experiments.BUDGETS))
    parser.add_argument("--shapes", type=int, default=600, help="shapes of the one-by-one rows (600)")
    parser.add_argument("--json", default=None, help="also write the results to this JSON file")
    return parser.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""
    load = os.getloadavg()[0]
    coll = opnet.data.load_collection("humans", args.preset)
    for path in opnet.data.default_root().glob("*.channel.bench_radial_area*"):
        path.unlink()  # a cache of an earlier run of this benchmark
    n, k = coll.vertices.shape[1], coll.base_basis.k
    results = {"date": time.strftime("%Y-%m-%d"), "preset": args.preset, "shapes": len(coll), "vertices": n, "k": k}
    results |= {"cpu_count": os.cpu_count(), "loadavg_1min_at_start": round(load, 2)}
    _, results["batched_first_s"] = timed(lambda: coll.with_channels([RadialArea()], progress=False))
    _, results["batched_cached_s"] = timed(lambda: coll.with_channels([RadialArea()], progress=False))
    offsets = [opnet.inner_products.get_inner_product(name) for name in ("offset_area", "offset_conformal")]
    _, results["offset_builtin_s"] = timed(lambda: coll.with_channels(offsets, recompute=True, progress=False))
    few = coll.subset(np.arange(min(args.shapes, len(coll))))
    _, results["area_builtin_s"] = timed(lambda: few.with_channels([opnet.AreaInnerProduct()], recompute=True))
    one, results["one_by_one_serial_s"] = timed(lambda: few.with_channels([RadialAreaOneByOne()], n_jobs=1))
    par, results["one_by_one_processes_s"] = timed(lambda: few.with_channels([RadialAreaOneByOne()], n_jobs=-1))
    assert np.array_equal(one.operators, par.operators)
    results["one_by_one_shapes"] = len(few)
    results["loadavg_1min_at_end"] = round(os.getloadavg()[0], 2)
    return results


def report(r: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    per = r["batched_first_s"] / r["shapes"] * 1e3
    few = r["one_by_one_shapes"]
    speedup = r["one_by_one_serial_s"] / r["one_by_one_processes_s"]
    return "\n".join(
        [
            f"humans at `{r['preset']}`: {r['shapes']} shapes, {r['vertices']} vertices, k = {r['k']}.",
            "",
            "| what | shapes | seconds | ms/shape |",
            "|---|---:|---:|---:|",
            f"| new batched channel (`project_batch`), first call: computed and cached | {r['shapes']} | "
            f"{r['batched_first_s']:.1f} | {per:.2f} |",
            f"| the same, asked again: read from its cache file | {r['shapes']} | {r['batched_cached_s']:.2f} | "
            f"{r['batched_cached_s'] / r['shapes'] * 1e3:.3f} |",
            f"| channel with `project` only, shape by shape in this process | {few} | "
            f"{r['one_by_one_serial_s']:.1f} | {r['one_by_one_serial_s'] / few * 1e3:.1f} |",
            f"| the same in processes (`n_jobs=-1`) | {few} | {r['one_by_one_processes_s']:.1f} | "
            f"{r['one_by_one_processes_s'] / few * 1e3:.1f} |",
            f"| built-in area, batched, on the same shapes | {few} | {r['area_builtin_s']:.2f} | "
            f"{r['area_builtin_s'] / few * 1e3:.2f} |",
            *(
                [
                    f"| built-in offset channels (`offset_area` + `offset_conformal`), computed anew and cached | "
                    f"{r['shapes']} | {r['offset_builtin_s']:.1f} | {r['offset_builtin_s'] / r['shapes'] * 1e3:.2f} |"
                ]
                if "offset_builtin_s" in r
                else []
            ),
            "",
            f"The processes are {speedup:.2f}× as fast as this process alone. Measured {r['date']} on "
            f"{r['cpu_count']} cores; load average {r['loadavg_1min_at_start']} at the start, "
            f"{r['loadavg_1min_at_end']} at the end.",
        ]
    )


def main(argv=None) -> None:
    run_benchmark("A channel of one's own", parse_args, measure, report, argv)


if __name__ == "__main__":
    main()
