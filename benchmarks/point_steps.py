"""Benchmark: a training step of each point-set autoencoder, side by side.

Times full training steps (forward, the Kabsch-aligned loss of eq. 9, backward, the fused Adam of
``opnet.train.fit``) of the PointNet AE (``architecture="pointnet"``), PointNet with its input transform
(``"pointnet_stn"``) and the PointNet++ autoencoder (``"pointnet2"``; and, beside it, the same network evaluated as
first written, each level's MLP on the concatenated groups: what ``PointNet2Autoencoder.encode`` saves), on
synthetic vertices of the humans' size (1229 vertices; the encoders read 256 of them, as ``fit`` does by default) at
the ``default`` budget's batch size.
The architectures take turns within each repeat, so a load on the machine falls on all of them; the report gives
each one's best and median seconds per step and its ratio to the PointNet AE's: what ``reproduce --points`` costs
beside the PointNet AE (``opnet.experiments.plan.POINT_VARIANTS``). ``--json PATH`` writes the result
(``benchmarks/results/point_steps.json`` is the shipped one).

Run::

    .venv/bin/python benchmarks/point_steps.py                     # ~1 min on one thread
    .venv/bin/python benchmarks/point_steps.py --json results/point_steps.json
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import torch
from shape_differences import load_span, measured, run_benchmark, torch_machine_info

from opnet.experiments.plan import BUDGETS
from opnet.model import ARCHITECTURES, PointNet2Autoencoder, farthest_points, rigid_alignment_loss
from opnet.train.loop import adam


class ConcatenatedPointNet2(PointNet2Autoencoder):
    """PointNet++ as first written: each level's whole MLP on every group member's concatenated ``[offset,
    feature]``, then ``amax``; timed beside :class:`~opnet.model.PointNet2Autoencoder`, whose codes and gradients
    ``tests/test_apps.py`` checks against the same abstraction written as a loop over the groups.
    """

    def encode(self, vertices):
        xyz, features = vertices[:, self.point_index], None
        b = torch.arange(len(xyz))[:, None, None]
        for (centres, group, _), radius, level in zip(self.LEVELS, self.radius, self.levels):
            centres, group = min(centres, xyz.shape[1]), min(group, xyz.shape[1])
            centre = torch.gather(xyz, 1, farthest_points(xyz, centres)[..., None].expand(-1, -1, 3))
            near, idx = torch.cdist(centre, xyz).topk(group, dim=-1, largest=False)
            idx = torch.where(near <= radius, idx, idx[..., :1])
            grouped = xyz[b, idx] - centre[:, :, None]
            if features is not None:
                grouped = torch.cat([grouped, features[b, idx]], dim=-1)
            xyz, features = centre, level(grouped).amax(dim=2)
        return self.global_mlp(torch.cat([xyz, features], dim=-1)).amax(dim=1)


#: The networks timed, by the name the report gives them; the first is the reference of the ratios.
NETWORKS = {name: ARCHITECTURES[name][0] for name in ("pointnet", "pointnet_stn", "pointnet2")}
NETWORKS["pointnet2, concatenated groups"] = ConcatenatedPointNet2


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--batch-size", type=int, default=BUDGETS["default"].batch_size, help="shapes per step")
    ap.add_argument("--vertices", type=int, default=1229, help="vertices of each shape (1229: the humans)")
    ap.add_argument("--points", type=int, default=256, help="vertices the encoders read (fit's default)")
    ap.add_argument("--repeats", type=int, default=7, help="timed steps of each architecture (after a warm-up)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (1: as each of reproduce --jobs 2)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def measure(args) -> dict:
    """Run the benchmark described by ``args`` (:func:`parse_args`); everything it measured, as JSON-able data."""
    torch.set_num_threads(args.threads)
    rng = np.random.default_rng(0)
    base = rng.normal(size=(args.vertices, 3))
    x = torch.as_tensor(base + 0.01 * rng.normal(size=(args.batch_size, args.vertices, 3)), dtype=torch.float32)
    steps, seconds = {}, {name: [] for name in NETWORKS}
    for name, network in NETWORKS.items():
        torch.manual_seed(0)
        net = network(args.vertices, args.points).choose_points(base)
        optimizer = adam(net.parameters(), 1e-3)

        def step(net=net, optimizer=optimizer):
            optimizer.zero_grad(set_to_none=True)
            rigid_alignment_loss(net(x), x).backward()
            optimizer.step()

        step()  # warm-up
        steps[name] = (step, sum(p.numel() for p in net.parameters()))
    machine = torch_machine_info()
    for _ in range(args.repeats):
        for name, (step, _) in steps.items():
            start = time.perf_counter()
            step()
            seconds[name].append(time.perf_counter() - start)
    rows = [
        dict(
            architecture=name,
            parameters=steps[name][1],
            best_s=min(seconds[name]),
            median_s=float(np.median(seconds[name])),
        )
        for name in NETWORKS
    ]
    machine["loadavg_1min_at_end"] = round(os.getloadavg()[0], 2)
    fields = dict(batch_size=args.batch_size, vertices=args.vertices, points=args.points, repeats=args.repeats)
    return dict(date=time.strftime("%Y-%m-%d"), **fields, machine=machine, rows=rows)


def report(r: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    ref = r["rows"][0]
    out = [
        f"Training steps of batch {r['batch_size']} ({r['vertices']} vertices a shape, the encoders reading "
        f"{r['points']}): forward, eq. 9's loss, backward, Adam; {r['repeats']} steps each, the architectures taking "
        "turns.",
        "",
        f"| architecture | parameters | best s/step | median s/step | median / {ref['architecture']}'s |",
        "|---|---:|---:|---:|---:|",
    ]
    out += [
        f"| {x['architecture']} | {x['parameters']:,} | {x['best_s']:.3f} | {x['median_s']:.3f} | "
        f"{x['median_s'] / ref['median_s']:.2f}× |"
        for x in r["rows"]
    ]
    out += ["", measured(r["date"], r["machine"]) + " " + load_span(r["machine"])]
    return "\n".join(out)


def main(argv=None):
    run_benchmark("Point-set autoencoders' training steps", parse_args, measure, report, argv)


if __name__ == "__main__":
    main()
