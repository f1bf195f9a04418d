"""The configs of ``python -m opnet reproduce`` and ``evaluate``: frozen dataclasses whose fields generate the
commands' options (:mod:`opnet.options`), as :class:`opnet.train.TrainConfig` does for ``train``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

from ..data.profiles import PROFILES, profile, reproducible
from ..inner_products import get_inner_product, split_channels
from ..options import option, positive_int
from .plan import ABLATION_GRIDS, BUDGETS, PARTS, PRESETS, TRAINING_BUDGETS, Budget
from .shipped import shipped_presets

__all__ = ["ReproduceConfig", "EvaluateConfig"]


@dataclass(frozen=True)
class ReproduceConfig:
    """What a reproduction runs (:func:`opnet.reproduce.reproduce`): the preset and collection, the parts of the plan
    (:data:`~opnet.experiments.plan.PARTS`), the ablation's channel sets of one's own, and where it writes.

    ``maps`` and ``bodies`` ``None`` (the default): as the collection's profile allows
    (:attr:`~opnet.data.profiles.Profile.computed_maps`, :attr:`~opnet.data.profiles.Profile.more_bodies`); so is
    ``applications`` (:attr:`~opnet.data.profiles.Profile.applications`). Asking for a part the profile does not
    allow is refused, naming the option that turns it off.
    """

    preset: str = option(
        "quick",
        "quick: minutes on a laptop CPU; default: 3 seeds of every network, about half a day on 2 cores; paper: GPU",
        choices=PRESETS,
    )
    collection: str = option(
        "humans", "a registered collection profile (humans: the paper's Table 1 beside ours; animals: quadrupeds)"
    )
    out: str | None = option(None, "output folder (default reproduce-<preset>, reproduce-<collection>-<preset>)")
    device: str = option("auto", "auto, cpu, cuda")
    ablation: bool = option(True, "only Table 1 and the rows beside it: no ablation grid")
    figures: bool = option(True, "skip the PNG figures")
    applications: bool | None = option(
        None, "skip the PointNet autoencoder and the analogy / interpolation benchmarks", switch=True
    )
    refine: bool = option(True, "skip the operator-matching rows (geometric baseline, FuncChar, SfL, + refinement)")
    points: bool = option(
        False,
        "also train the other point-set autoencoders (PointNet with its spatial transformer, PointNet++: "
        "plan.POINT_VARIANTS), with Table 1, analogy and interpolation rows; a PointNet++ training costs about four "
        "times the PointNet AE's",
    )
    from_shipped: bool = option(
        False,
        "when the folder holds no results.json yet, start from the shipped results of this preset and collection: "
        "their rows stand (their trainings are not on this machine) until this call measures them again, so that "
        "--points, say, adds its rows without the other parts being trained again; a run this call trains again "
        "replaces its rows, or drops them where its checkpoint differs",
    )
    maps: bool | None = option(
        None,
        "skip the computed-map rows (Table 1's Comp networks, other triangulations; maps take about 0.6 s per shape "
        "and core; collections with computed_maps in their profile)",
        switch=True,
    )
    bodies: bool | None = option(
        None,
        "skip the rows of our variant trained with more distinct bodies and random poses (plan.MORE_BODIES)",
        switch=True,
    )
    ablation_grid: str | None = option(
        None,
        "the ablation's networks: full (every input set at depths 1-4, 28 networks) or cross (every set at depth 1 "
        "and A+E+C at depths 1-4, 10 networks: the cells the paper's ablation claims read); default the preset's",
        choices=ABLATION_GRIDS,
    )
    ablation_channels: tuple = option(
        (),
        "a channel set of your own for the ablation grid, e.g. area,mymodule:MyIP (repeat for several); added "
        "beside the paper's seven sets",
        append=True,
    )
    seeds: int | None = option(
        None,
        "train each network of Table 1, the Comp rows and the ablation with this many seeds (0, 1, ...; default the "
        "preset's: 1 at quick, 3 at default and paper): rows then "
        "hold each seed's mean, the spread and a 95 %% interval (over seeds and shapes), and the claims are judged",
        type=positive_int,
    )
    data_root: str | None = option(None, "where collections are cached")
    jobs: int = option(
        1,
        "train this many networks side by side, each in its own process with an equal share of the cores (2 on 2 "
        "cores: about 1.9 times the networks per hour); a network's round-off then differs from one trained alone. "
        "Each entry's rows are written once its own trainings are finished, while later ones train (this process "
        "evaluates beside them, on the same cores: their train_seconds include that)",
        type=positive_int,
    )
    training_budget: str | None = option(
        None,
        "train with a named budget instead of the preset's: paper-code (the paper's published code: 450 epochs, "
        "Adam 1e-4 constant, batch 32; for a GPU or a long run)",
        flag="--budget",
        choices=tuple(TRAINING_BUDGETS),
    )
    budget: Budget | None = option(None, "training settings (default BUDGETS[preset])", cli=False)
    progress: bool | None = option(
        None, "None: one bar over the plan; True: also a bar per network; False: none", cli=False
    )

    def __post_init__(self):
        if self.preset not in BUDGETS:
            raise ValueError(f"unknown preset {self.preset!r}; use one of {list(BUDGETS)}.")
        if self.collection not in reproducible():
            known = self.collection in PROFILES
            raise ValueError(
                f"{'the collection' if known else 'unknown collection'} {self.collection!r}"
                f"{' has a profile that reproduce does not offer (reproducible=False)' if known else ''}; reproduce "
                f"runs on one of {list(reproducible())} (opnet.data.register_profile adds one)."
            )
        p = profile(self.collection)
        for name, allowed, why in (
            ("maps", p.computed_maps, "needs other triangulations of its shapes"),
            ("bodies", p.more_bodies, "needs a generator that draws new bodies"),
            ("applications", p.applications, "needs a generator's ground truth"),
        ):
            if getattr(self, name) and not allowed:
                raise ValueError(
                    f"the {name} rows of the {self.collection} are not in its profile ({why}): pass {name}=False "
                    f"(the command line's --no-{name})."
                )
        if self.from_shipped and self.preset not in shipped_presets(self.collection):
            raise ValueError(
                f"from_shipped: no shipped reproduction of the {self.collection} at preset {self.preset!r} (shipped: "
                f"{shipped_presets(self.collection) or 'none'}); drop --from-shipped or pick a shipped preset."
            )
        if isinstance(self.ablation_channels, str):
            raise TypeError("ablation_channels must be a sequence of channel sets, e.g. ('area,mymodule:MyIP',).")
        sets = tuple(self.ablation_channels)
        for s in sets:
            if not split_channels(s):
                raise ValueError(f"an ablation channel set is empty: {s!r}; give e.g. 'area,mymodule:MyIP'.")
            for channel in split_channels(s):  # unknown or unimportable: refused now, not after Table 1's training
                get_inner_product(channel)
        object.__setattr__(self, "ablation_channels", sets)
        if self.training_budget is not None and self.training_budget not in TRAINING_BUDGETS:
            raise ValueError(
                f"unknown training budget {self.training_budget!r}; the named budgets are {list(TRAINING_BUDGETS)}."
            )
        if self.budget is not None and not isinstance(self.budget, Budget):
            raise TypeError(f"budget must be an opnet.experiments.plan.Budget, got {type(self.budget).__name__}.")
        if self.seeds is None:  # the preset's
            object.__setattr__(self, "seeds", self.training.seeds)
        if self.ablation_grid is None:
            object.__setattr__(self, "ablation_grid", self.training.ablation_grid)
        if self.ablation_grid not in ABLATION_GRIDS:
            raise ValueError(f"ablation_grid must be one of {ABLATION_GRIDS}, got {self.ablation_grid!r}.")
        if isinstance(self.seeds, bool) or not isinstance(self.seeds, int) or self.seeds < 1:
            raise ValueError(f"seeds must be a count of trainings >= 1, got {self.seeds!r}.")
        if isinstance(self.jobs, bool) or not isinstance(self.jobs, int) or self.jobs < 1:
            raise ValueError(f"jobs must be a count of processes >= 1, got {self.jobs!r}.")

    @property
    def profile(self):
        """The collection's :class:`~opnet.data.profiles.Profile`."""
        return profile(self.collection)

    @property
    def training(self) -> Budget:
        """:attr:`budget`, or the preset's, with the training fields of :attr:`training_budget` when one is named."""
        budget = self.budget or BUDGETS[self.preset]
        if self.training_budget is None:
            return budget
        return replace(budget, **TRAINING_BUDGETS[self.training_budget])

    def parts(self) -> tuple[str, ...]:
        """The parts of the plan this reproduction runs (a ``None`` flag: its profile's choice)."""
        p = self.profile
        chosen = dict(
            table1=True,
            applications=p.applications if self.applications is None else self.applications,
            refine=self.refine,
            maps=p.computed_maps if self.maps is None else self.maps,
            bodies=p.more_bodies if self.bodies is None else self.bodies,
            ablation=self.ablation,
            points=self.points,
        )
        return tuple(part for part in PARTS if chosen[part])

    def as_dict(self) -> dict:
        """The fields, as keyword arguments."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class EvaluateConfig:
    """What ``python -m opnet evaluate`` evaluates: a run's best checkpoint on its collection's test sets, beside the
    nearest-neighbour (same channels) and base-shape baselines.
    """

    run_dir: str = option(None, "a folder written by `python -m opnet train`", required=True)
    collection: str | None = option(
        None,
        "the saved collection's .json the run was trained on, when it is not a generated one (default: the run's own)",
    )
    device: str = option("auto", "auto, cpu, cuda")
    json: str | None = option(None, "also write the rows to this JSON file")
    data_root: str | None = option(None, "where collections are cached")

    def __post_init__(self):
        if not self.run_dir:
            raise ValueError("evaluate needs the run's folder: --run-dir DIR (run_dir=).")
