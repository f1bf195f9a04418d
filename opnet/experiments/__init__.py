"""The experiment layer: runs declared as data (:class:`~opnet.experiments.spec.RunSpec`), trained or loaded and
evaluated by one runner into rows with structured fields (:class:`~opnet.experiments.runner.Results`), and the
ablation over any channels (:func:`~opnet.experiments.runner.ablation`).

::

    sets = (["area"], ["area", MyIP()])
    specs = [opnet.experiments.RunSpec(channels=c, depth=d, epochs=20) for c in sets for d in (1, 2)]
    runs = [opnet.experiments.train_run(s, coll, "runs/mine") for s in specs]      # resumable, one folder each
    rows = opnet.experiments.evaluate_runs(runs, coll, ("val",))
    table = opnet.ablation(coll, channel_sets=[["area"], ["area", MyIP()]], depths=[1, 2], epochs=20)

:mod:`opnet.experiments.plan` declares the reproduction's entries (networks, baselines, refinements) and
:func:`~opnet.experiments.runner.run_entries` runs them with the same runner (:mod:`opnet.reproduce` selects them);
:func:`~opnet.experiments.shipped.shipped_results` reads the `default` reproductions that ship with opnet (the
humans', and the animals' with ``collection="animals"``).
"""

from .baselines import BASELINES, register_baseline
from .config import EvaluateConfig, ReproduceConfig
from .paper import PAPER_ABLATION, PAPER_TABLE1
from .plan import BUDGETS, Budget, Entry, Plan, declare, select
from .report import results_markdown
from .runner import Results, Run, Workspace, ablation, evaluate_runs, run_entries, train_run
from .shipped import shipped_figure, shipped_results
from .spec import RunSpec
from .stats import Comparison, Interval, compare
from .targets import TARGETS, Target, judge

__all__ = [
    "RunSpec",
    "Run",
    "Results",
    "train_run",
    "evaluate_runs",
    "ablation",
    "Entry",
    "Plan",
    "declare",
    "select",
    "Budget",
    "BUDGETS",
    "BASELINES",
    "register_baseline",
    "Workspace",
    "run_entries",
    "Target",
    "TARGETS",
    "judge",
    "compare",
    "Comparison",
    "Interval",
    "ReproduceConfig",
    "EvaluateConfig",
    "results_markdown",
    "shipped_results",
    "shipped_figure",
    "PAPER_TABLE1",
    "PAPER_ABLATION",
]
