"""Benchmark: adding a channel of one's own to a collection (``Collection.with_kinds``).

Times, on the humans collection of a preset (built or read from ``$OPNET_DATA_DIR``, not counted):

- a new channel with a batched ``project_batch`` over every shape: the first call (computed and cached beside the
  collection) and the second (read back from the cache);
- a channel with ``project`` only (shape by shape) on ``--shapes`` shapes, in this process and in processes
  (``n_jobs=-1``), side by side in one run: the ratio is what the processes buy on this machine;
- the built-in area channel through the same batched path, as the reference.

Run::

    .venv/bin/python benchmarks/channels.py                    # the default humans (5856 shapes)
    .venv/bin/python benchmarks/channels.py --preset quick
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--preset", default="default", choices=["quick", "default", "paper"])
    parser.add_argument("--shapes", type=int, default=600, help="shapes of the one-by-one rows (600)")
    parser.add_argument("--json", default=None, help="also write the results to this JSON file")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")

    coll = opnet.data.load_collection("humans", args.preset)
    for path in opnet.data.default_root().glob("*.channel.bench_radial_area*"):
        path.unlink()  # a cache of an earlier run of this benchmark
    n, k = coll.vertices.shape[1], coll.base_basis.k
    print(f"humans/{args.preset}: {len(coll)} shapes, {n} vertices, k = {k}")

    results = {"preset": args.preset, "shapes": len(coll), "vertices": n, "k": k}
    _, results["batched_first_s"] = timed(lambda: coll.with_kinds([RadialArea()], progress=False))
    _, results["batched_cached_s"] = timed(lambda: coll.with_kinds([RadialArea()], progress=False))
    few = coll.subset(np.arange(min(args.shapes, len(coll))))
    _, results["area_builtin_s"] = timed(lambda: few.with_kinds([opnet.AreaInnerProduct()], recompute=True))
    one, results["one_by_one_serial_s"] = timed(lambda: few.with_kinds([RadialAreaOneByOne()], n_jobs=1))
    par, results["one_by_one_processes_s"] = timed(lambda: few.with_kinds([RadialAreaOneByOne()], n_jobs=-1))
    assert np.array_equal(one.operators, par.operators)
    results["one_by_one_shapes"] = len(few)

    per = results["batched_first_s"] / len(coll) * 1e3
    print(f"new batched channel, all {len(coll)} shapes: {results['batched_first_s']:.1f} s ({per:.2f} ms/shape)")
    print(f"  asked again (read from its cache file): {results['batched_cached_s']:.2f} s")
    print(f"one-by-one channel, {len(few)} shapes: {results['one_by_one_serial_s']:.1f} s in this process, ")
    print(
        f"  {results['one_by_one_processes_s']:.1f} s in processes "
        f"({results['one_by_one_serial_s'] / results['one_by_one_processes_s']:.2f}× faster)"
    )
    print(f"built-in area recomputed on the same {len(few)} shapes (batched): {results['area_builtin_s']:.2f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
