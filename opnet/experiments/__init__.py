"""The experiment layer: runs declared as data (:class:`~opnet.experiments.spec.RunSpec`), trained or loaded and
evaluated by one runner into rows with structured fields (:class:`~opnet.experiments.runner.Results`), and the
ablation over any channels (:func:`~opnet.experiments.runner.ablation`).

::

    sets = (["area"], ["area", MyIP()])
    specs = [opnet.experiments.RunSpec(channels=c, depth=d, epochs=20) for c in sets for d in (1, 2)]
    runs = [opnet.experiments.train_run(s, coll, "runs/mine") for s in specs]      # resumable, one folder each
    rows = opnet.experiments.evaluate_runs(runs, coll, ("val",))
    table = opnet.ablation(coll, channel_sets=[["area"], ["area", MyIP()]], depths=[1, 2], epochs=20)

:mod:`opnet.reproduce` declares the paper's networks this way and runs them with the same runner;
:func:`~opnet.experiments.shipped.shipped_results` reads the `default` reproductions that ship with opnet (the
humans', and the animals' with ``collection="animals"``).
"""

from .paper import PAPER_ABLATION, PAPER_TABLE1
from .report import results_markdown
from .runner import Results, Run, ablation, evaluate_runs, train_run
from .shipped import shipped_figure, shipped_results
from .spec import RunSpec

__all__ = [
    "RunSpec",
    "Run",
    "Results",
    "train_run",
    "evaluate_runs",
    "ablation",
    "results_markdown",
    "shipped_results",
    "shipped_figure",
    "PAPER_TABLE1",
    "PAPER_ABLATION",
]
