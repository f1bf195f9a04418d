"""The one runner: train (or load) each declared run in its folder, evaluate the networks into rows, and the
ablation over any channels (:func:`ablation`, :func:`opnet.ablation`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from ..evaluate import evaluate, nearest_neighbour_method, operatornet_method, pointnet_method
from .spec import RunSpec

__all__ = ["Run", "Results", "train_run", "evaluate_runs", "ablation"]


@dataclass(eq=False)
class Run:
    """A trained (or loaded) run: its spec, network, history, folder (``None`` in memory) and ``info`` (``epochs``,
    ``train_seconds``, ``device``: what its rows report).
    """

    spec: RunSpec
    net: object
    history: list
    run_dir: Path | None
    info: dict = field(default_factory=dict)

    def method(self, collection):
        """The :class:`opnet.evaluate.Method` of this run's network on ``collection``, named by :attr:`RunSpec.label`,
        its rows carrying the spec's fields and the run's info.
        """
        if self.spec.architecture == "pointnet":
            m = pointnet_method(self.net, collection, self.spec.label)
        else:
            m = operatornet_method(self.net, collection, self.spec.label)
        m.info = {**self.spec.fields(), **self.info}
        return m


class Results(list):
    """Rows (dicts with structured fields: ``method``, ``run``, ``channels``, ``depth``, ``split``, ``d_R`` ...),
    shown in a notebook as a Markdown table of ``d_R`` (×10⁻⁴). :meth:`pivot` lays them out as the paper's ablation.
    """

    def pivot(self, metric: str = "d_R", split: str | None = None, scale: float = 1e4) -> dict:
        """``{channels label: {depth: value}}`` of ``metric`` (× ``scale``) for the rows of one split (default: the
        first one present), one entry per run; baselines (no depth) go under depth ``None``.
        """
        from ..evaluate import channel_label

        split = split or next((r["split"] for r in self), None)
        out: dict = {}
        for r in self:
            if r["split"] == split and r.get(metric) is not None:
                key = channel_label(r["channels"]) if r["channels"] else r["method"]
                if r.get("variant") not in (None, "paper"):  # runs that differ by more than channels and depth
                    key += f" ({r['variant']})"
                out.setdefault(key, {})[r.get("depth")] = r[metric] * scale
        return out

    def markdown(self, metric: str = "d_R", split: str | None = None, scale: float = 1e4) -> str:
        """The :meth:`pivot` as a Markdown table: a row per channel set, a column per depth."""
        table = self.pivot(metric, split, scale)
        depths = sorted({d for row in table.values() for d in row}, key=lambda d: (d is None, d or 0))
        head = ["channels", *[f"depth {d}" if d is not None else "baseline" for d in depths]]
        split = split or next((r["split"] for r in self), "")
        lines = [
            f"{metric} ×{1 / scale:g} on {split}" if scale != 1 else f"{metric} on {split}",
            "",
            "| " + " | ".join(head) + " |",
            "|" + "---|" * len(head),
        ]
        for key, row in table.items():
            cells = [f"{row[d]:.3f}" if d in row else "" for d in depths]
            lines.append("| " + " | ".join([key, *cells]) + " |")
        return "\n".join(lines)

    def _repr_markdown_(self) -> str:
        return self.markdown()


def train_run(spec, collection, run_root=None, *, device="auto", progress=None):
    """Train ``spec`` (a :class:`~opnet.experiments.spec.RunSpec`) on ``collection`` in ``run_root / spec.run_name``
    (:func:`opnet.train.fit`: an interrupted run continues from its last epoch, a finished one is loaded), or in
    memory when ``run_root`` is ``None``; a :class:`Run`.
    """
    from ..train import fit

    run_dir = spec.run_dir(run_root)
    net, history = fit(collection, device=device, run_dir=run_dir, progress=progress, **spec.fit_options())
    trained_on = str(next(net.parameters()).device)
    if run_dir is not None:  # a reused run may have been trained elsewhere
        trained_on = json.loads((run_dir / "config.json").read_text())["device"]
    info = dict(epochs=len(history), train_seconds=round(sum(e["seconds"] for e in history), 1), device=trained_on)
    return Run(spec, net, history, run_dir, info)


def evaluate_runs(runs, collection, test_sets=("val",), *, extra: dict | None = None):
    """Rows (:class:`Results`) of every run's network on ``collection`` (:func:`opnet.evaluate.evaluate` on
    ``test_sets``).
    """
    return Results(evaluate(collection, [run.method(collection) for run in runs], test_sets, extra=extra))


def ablation(
    collection,
    channel_sets,
    depths=(1,),
    epochs: int = 50,
    *,
    run_root=None,
    test_sets=("val",),
    baselines: bool = True,
    device="auto",
    progress=None,
    **train_options,
):
    """The ablation of Appendix B over any channels: OperatorNet trained on each set of ``channel_sets`` at each of
    ``depths`` for ``epochs``, evaluated on ``test_sets`` (default ``val``, where experiments are chosen; the test
    sets belong to a final evaluation), beside the nearest-neighbour baseline on the same channels.

    Parameters
    ----------
    collection : a collection holding every channel asked for (add yours with
        :meth:`~opnet.data.storage.Collection.with_kinds`).
    channel_sets : a list of channel sets (each a list of names or inner products, or a short name like ``"A+E"``).
    depths : encoder depths (1–4).
    epochs : training epochs of each network.
    run_root : where each run gets its folder (resumable; a finished run is loaded); ``None``: in memory.
    baselines : also the nearest-neighbour rows (``depth`` ``None``) of each channel set.
    train_options : other fields of :class:`~opnet.experiments.spec.RunSpec` (``batch_size``, ``lr``, ``hidden``,
        ``variant``, ``seed``).

    Returns
    -------
    opnet.experiments.runner.Results : one row per (run, test set), and per (baseline, test set);
        ``Results.markdown()`` pivots them.
    """
    from tqdm.auto import tqdm

    specs = [
        RunSpec(channels=channels, depth=depth, epochs=epochs, group="ablation", **train_options)
        for channels in channel_sets
        for depth in depths
    ]
    bar = tqdm(specs, desc="ablation", unit="network", disable=progress is False)
    runs = []
    for spec in bar:
        bar.set_postfix_str(spec.label)
        runs.append(train_run(spec, collection, run_root, device=device, progress=progress is True))
    rows = evaluate_runs(runs, collection, test_sets)
    if baselines:
        seen = []
        for spec in specs:
            if spec.channel_names not in seen:
                seen.append(spec.channel_names)
                nn = nearest_neighbour_method(collection, spec.channels)
                nn.info = dict(run=None, architecture=None, variant=None, channels=list(spec.channel_names), depth=None)
                rows += evaluate(collection, [nn], test_sets)
    return rows
