"""The reproduction as a plan: every row of it declared once, as an :class:`Entry`, and the presets' budgets.

An entry is one method of the reproduction: a stable ``key``, the network it trains (a
:class:`~opnet.experiments.spec.RunSpec`, or several for an ensemble of seeds) or the baseline it builds (a key of
:data:`~opnet.experiments.baselines.BASELINES`), what it is trained and tested on, its table and test sets, the entry it
refines (:func:`opnet.reconstruct` from that entry's output), the paper's Table 1 row it stands beside, and the part of
the reproduction that selects it (:data:`PARTS`). :func:`declare` lists every entry of a budget; :func:`select` keeps
those a reproduction runs (its parts, and what the collection's :class:`~opnet.data.profiles.Profile` allows); the
runner (:mod:`opnet.experiments.runner`) trains, builds and evaluates each one into rows that carry ``entry=<key>``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from ..data.generators import PRESETS as DATA_PRESETS
from ..inner_products import channel_label, channel_names
from ..shape_difference import CHANNEL_SETS, KINDS
from .paper import PAPER_ABLATION_DEPTHS
from .spec import ARCHITECTURES, RunSpec

__all__ = [
    "Budget",
    "BUDGETS",
    "TRAINING_BUDGETS",
    "PRESETS",
    "TRAINING_FIELDS",
    "Entry",
    "Step",
    "Plan",
    "PARTS",
    "DATA",
    "TABLE1_ROWS",
    "PAPER_ROWS",
    "SUBSET_ENTRIES",
    "MORE_BODIES",
    "POINT_VARIANTS",
    "ABLATION_SETS",
    "ABLATION_DEPTHS",
    "ABLATION_GRIDS",
    "REFINE_SETS",
    "COMP_RESOLUTION",
    "LABELS_RESOLUTION",
    "spec",
    "bodies_group",
    "declare",
    "select",
    "ablation_entries",
    "ablation_label",
]


@dataclass(frozen=True)
class Budget:
    """Training settings of a preset: Table 1's epochs, the ablation's, batch size, peak learning rate and its
    schedule, and how much is evaluated (refinement steps and shapes, analogy questions, interpolation paths,
    other-mesh shapes).

    ``schedule`` (:data:`opnet.train.SCHEDULES`) is the learning rate over a run of the paper's network and the
    PointNet autoencoder; ``None``: each variant's own (constant for the paper's, one-cycle for ours). Our variant
    always trains with its one-cycle schedule. ``seeds``: the trainings of each network a reproduction at this
    preset makes by default (``reproduce --seeds``); ``ablation_grid``: its ablation's grid
    (:data:`~opnet.experiments.plan.ABLATION_GRIDS`).
    """

    epochs: int
    ablation_epochs: int
    batch_size: int = 32
    lr: float = 1e-3
    hidden: int = 1024
    schedule: str | None = None
    refine_steps: int = 300
    refine_shapes: int = 80
    pointnet_epochs: int = 60
    analogies: int = 100  # analogy questions per kind
    paths: int = 10  # interpolation paths per kind
    apps_refine_shapes: int = 24  # shapes per kind the applications refine (seconds each)
    discretisation_shapes: int = 80  # test shapes the different-discretisation rows map (seconds each)
    seeds: int = 1
    ablation_grid: str = "full"


#: The fields of a :class:`Budget` that the networks are trained with (the others set how much is evaluated).
TRAINING_FIELDS = ("epochs", "ablation_epochs", "pointnet_epochs", "batch_size", "lr", "hidden", "schedule")
#: The training settings (:class:`Budget`) of each preset: the one list of the presets.
BUDGETS = {
    # chosen on `val` (benchmarks/schedules.py --preset quick, 3 seeds): at 60 epochs the constant rate never
    # converged and the one-cycle rate stopped higher; one-cycle at a peak of 3e-3 converged with the lowest mean.
    # Its epochs: 120 (2026-12-05), then 80 measured beside 120 on another machine (2026-12-06: 3.88 ± 0.29 against
    # 3.47 ± 0.44 ×10⁻⁴; 120 converged on 2 seeds of 3, so the rule left it out; the ranges overlap; 58 s a network
    # against 97 s; benchmarks/results/schedules-quick-short.json). The PointNet AE, 3 seeds on `val`: 40 epochs
    # 11.8e-4 mean, all converged (20 epochs: 60.7e-4; its old constant 1e-3 for 20 epochs: 48.0e-4, none converged)
    "quick": Budget(
        epochs=80,
        ablation_epochs=6,
        batch_size=16,
        lr=3e-3,
        schedule="onecycle",
        refine_steps=30,
        refine_shapes=12,
        pointnet_epochs=40,
        analogies=24,
        paths=4,
        apps_refine_shapes=6,
        discretisation_shapes=12,
    ),
    # chosen on `val` (benchmarks/schedules.py): the one-cycle schedule, whose validation curve flattens; the
    # ablation at Table 1's budget; three seeds of every network
    "default": Budget(epochs=60, ablation_epochs=60, schedule="onecycle", seeds=3, ablation_grid="cross"),
    "paper": Budget(epochs=100, ablation_epochs=100, schedule="onecycle", seeds=3),
}
#: Training budgets asked for by name (``reproduce --budget NAME``, ``ReproduceConfig(training_budget=)``): the
#: training fields they set; the evaluation fields stay the preset's. ``paper-code``: the budget of the paper's
#: published code (450 epochs, Adam at a constant 10⁻⁴, batch 32), for a GPU or a long run.
TRAINING_BUDGETS = {
    "paper-code": dict(
        epochs=450, ablation_epochs=450, pointnet_epochs=450, batch_size=32, lr=1e-4, schedule="constant"
    ),
}
#: The presets' names, in order of size: the data's (:data:`opnet.data.generators.PRESETS`, the collections' sizes),
#: each with its training budget here.
PRESETS = tuple(DATA_PRESETS)

#: The parts of a reproduction (each selects its entries; ``table1`` always runs): Table 1's networks and baselines;
#: the PointNet autoencoder and the analogy / interpolation benchmarks; the operator-matching rows (seconds per
#: shape); the computed-map rows; the rows trained with more bodies; the ablation.
PARTS = ("table1", "applications", "refine", "maps", "bodies", "ablation", "points")
#: What an entry is trained or tested on: the collection (``base``), its operators through computed maps of the
#: :data:`COMP_RESOLUTION` meshes (``comp``), half exact and half ``comp`` (``half``, :func:`opnet.data.half_mapped`),
#: a third exact, a sixth through 5k maps, the rest ``comp`` (``three``, :func:`opnet.data.three_way_mapped`), the
#: collection with FuncChar's offset channels (``offsets``), or its shapes on the :data:`LABELS_RESOLUTION` mesh as
#: labels, from the base's operators (``labels``, :func:`opnet.data.labels_collection`).
DATA = ("base", "comp", "half", "three", "offsets", "labels")
#: The mesh of the finer labels of the paper's appendix (OperatorNet trained with 2k-vertex labels).
LABELS_RESOLUTION = "2k"
#: The mesh whose computed maps the "Comp" rows use.
COMP_RESOLUTION = "2k"
#: The test sets of the operator-matching rows (at most ``Budget.refine_shapes`` shapes of each).
REFINE_SETS = ("test", "test_subjects")
#: The ablation's columns (Appendix B, in the paper's order): short name → channels. ``reproduce``'s
#: ``ablation_channels`` adds sets of one's own.
ABLATION_SETS = dict(CHANNEL_SETS)
#: The ablation's encoder depths (its rows).
ABLATION_DEPTHS = PAPER_ABLATION_DEPTHS
#: The ablation's grids: ``full``, every set at every depth (the paper's Appendix B, 28 networks); ``cross``, every
#: set at depth 1 and A+E+C at every depth (10 networks: the cells its claims read).
ABLATION_GRIDS = ("full", "cross")


@dataclass(frozen=True)
class Entry:
    """One method of the reproduction, as data (see the module's docstring).

    Parameters
    ----------
    key : stable identity, in its rows' ``entry`` field (``"int+ext"``, ``"comp-ext"``, ``"int+ext+refined"``...).
    name : display name (the rows' ``method``; never parsed).
    runs : the networks it trains: one :class:`~opnet.experiments.spec.RunSpec`, or several (an ensemble of seeds, their
    outputs averaged).
    baseline : or the key of the baseline it builds (:data:`~opnet.experiments.baselines.BASELINES`).
    refines : or the key of the entry whose output it refines with :func:`opnet.reconstruct`.
    trained_on, tested_on : a key of :data:`DATA` (``tested_on`` default: ``comp`` for ``half`` and ``three``,
        else ``trained_on``).
    draws : ``load_collection`` keywords (``bodies``, ``poses``) of the collection it trains on (same held-out shapes).
    table : its rows' ``table``.
    test_sets : where it is evaluated (``None``: every test set of the collection, ``opnet.evaluate.test_sets_for``).
    part : the part of :data:`PARTS` that selects it.
    paper_row : the row of the paper's Table 1 it stands beside (``opnet.experiments.paper.PAPER_TABLE1``).
    other_meshes : its network also decodes test shapes given on other triangulations (the discretisation rows).
    fields : more structured fields of its rows (``bodies``, ``poses``, ``ensemble``: an ensemble's size...).
    """

    key: str
    name: str
    runs: tuple = ()
    baseline: str | None = None
    refines: str | None = None
    trained_on: str = "base"
    tested_on: str | None = None
    draws: dict = field(default_factory=dict, hash=False)
    table: str = "table1"
    test_sets: tuple | None = None
    part: str = "table1"
    paper_row: str | None = None
    other_meshes: bool = False
    fields: dict = field(default_factory=dict, hash=False)

    def __post_init__(self):
        runs = (self.runs,) if isinstance(self.runs, RunSpec) else tuple(self.runs)
        object.__setattr__(self, "runs", runs)
        if sum((bool(runs), self.baseline is not None, self.refines is not None)) != 1:
            raise ValueError(f"entry {self.key!r} needs exactly one of runs=, baseline= or refines=.")
        if self.part not in PARTS:
            raise ValueError(f"entry {self.key!r}: part must be one of {PARTS}, got {self.part!r}.")
        for name in ("trained_on", "tested_on"):
            value = getattr(self, name)
            if value is not None and value not in DATA:
                raise ValueError(f"entry {self.key!r}: {name} must be one of {DATA}, got {value!r}.")
        if "labels" in (self.trained_on, self.tested_on) and not runs:
            raise ValueError(f"entry {self.key!r}: only a network trains or tests on labels of another mesh.")
        if self.tested_on is None:  # a collection mixed of exact and mapped operators is tested like the Comp ones
            mixed = self.trained_on in ("half", "three")
            object.__setattr__(self, "tested_on", "comp" if mixed else self.trained_on)

    @property
    def replicated(self) -> bool:
        """Whether it trains its network with several seeds, each evaluated apart (:attr:`RunSpec.seeds`)."""
        return len(self.runs) == 1 and bool(self.runs[0].seeds)

    @property
    def spec(self) -> RunSpec:
        """Its (first) declared run; a ``ValueError`` for a baseline or a refinement."""
        if not self.runs:
            raise ValueError(f"entry {self.key!r} trains no network (a baseline or a refinement).")
        return self.runs[0]

    def match_fields(self) -> dict:
        """The fields that find this entry's rows in any results file, older ones included (whose rows have no
        ``entry``): a network's ``architecture``, ``variant``, ``group``, ``channels``, ``depth`` and ``refined``
        ``None``; a baseline's ``baseline`` and :attr:`fields`.
        """
        if self.baseline is not None:
            return dict(baseline=self.baseline, **self.fields)
        if self.refines is not None:
            raise ValueError(f"entry {self.key!r} is a refinement: find its rows by run and refined=True.")
        f = self.spec.fields()
        return dict({k: f[k] for k in ("architecture", "variant", "group", "channels", "depth")}, refined=None)

    def run_fields(self) -> dict:
        """The structured fields of its rows that name what it is: its run's (an ensemble's ``run``: the seeds' run
        names joined by ``+``) or ``baseline``, then :attr:`fields`.
        """
        if self.baseline is not None:
            return dict(baseline=self.baseline, **self.fields)
        out = self.spec.fields()
        if len(self.runs) > 1:
            out["run"] = "+".join(s.run_name for s in self.runs)
        return {**out, **self.fields}


@dataclass(frozen=True)
class Step:
    """A step of the plan that is not one method: the ``discretisation`` rows (every entry with ``other_meshes``) or
    the ``applications`` benchmarks; selected by ``part``.
    """

    key: str
    part: str


@dataclass(frozen=True)
class Plan:
    """The entries and steps a reproduction runs, in order; ``len(plan)`` is its progress bar's total."""

    entries: tuple
    steps: tuple = ()

    def __len__(self) -> int:
        return len(self.entries) + len(self.steps)

    def __getitem__(self, key: str) -> Entry:
        for e in self.entries:
            if e.key == key:
                return e
        raise KeyError(f"no entry {key!r} in this plan; it has {[e.key for e in self.entries]}.")

    def __contains__(self, key) -> bool:
        return any(e.key == key for e in self.entries)

    def keys(self) -> list[str]:
        return [e.key for e in self.entries]


def spec(group: str, budget: Budget, channels=KINDS, depth: int = 1, variant: str = "paper", **fields) -> RunSpec:
    """The declared run of one network of the reproduction: ``group`` names its folder's prefix, ``variant`` is
    ``"paper"``, ``"ours"`` or a point-set autoencoder's architecture (``"pointnet"``, ``"pointnet_stn"``,
    ``"pointnet2"``: :data:`~opnet.experiments.spec.ARCHITECTURES`, ``budget.pointnet_epochs``); the budget's
    epochs, batch size, learning rate, width and schedule (not for ``"ours"``, which keeps its own); ``fields``:
    other fields of :class:`~opnet.experiments.spec.RunSpec` (``name``, ``epochs``, ``seed``, ``options``).
    """
    pointnet = variant in ARCHITECTURES and variant != "operatornet"
    epochs = fields.pop("epochs", None) or (budget.pointnet_epochs if pointnet else budget.epochs)
    fields["options"] = dict(fields.get("options") or {})
    if variant != "ours":  # our variant keeps its one-cycle schedule
        fields.setdefault("schedule", budget.schedule)
    return RunSpec(
        channels=() if pointnet else channels,
        depth=depth,
        variant="paper" if pointnet else variant,
        architecture=variant if pointnet else "operatornet",
        epochs=epochs,
        batch_size=budget.batch_size,
        lr=budget.lr,
        hidden=budget.hidden,
        group=group,
        **fields,
    )


#: Table 1's rows of networks: key → (name, channels, variant, the paper's row it stands beside).
TABLE1_ROWS = {
    "int+ext": ("OperatorNet (Int+Ext)", KINDS, "paper", "OperatorNet (Int+Ext)"),
    "int": ("OperatorNet (Int)", ("area", "conformal"), "paper", "OperatorNet (Int)"),
    "ext": ("OperatorNet (Ext)", ("extrinsic",), "paper", "OperatorNet (Ext)"),
    "ours": ("OperatorNet ours (Int+Ext)", KINDS, "ours", None),
}
#: The other point-set autoencoders beside the PointNet AE of the paper's comparisons (section 7 and Fig. 17): key →
#: (name, architecture). The paper trained PointNet with and without its spatial transformer and kept the one without,
#: which did better; the appendix adds a PointNet++ autoencoder with the same decoder. They are the plan's part
#: ``points`` (``reproduce --points``): on the CPU a training step of PointNet++ costs about four times the PointNet
#: AE's, and of the transformer's PointNet about twice (``benchmarks/point_steps.py``: a batch of 32 shapes of the
#: humans' size, 1229 vertices, on one thread).
POINT_VARIANTS = {
    "pointnet-stn": ("PointNet AE (transformer)", "pointnet_stn"),
    "pointnet2": ("PointNet++ AE", "pointnet2"),
}
#: The rows beside Table 1 for unseen bodies: this project's variant trained on the collection drawn with more
#: bodies (and random poses) among its training shapes (``load_collection``'s ``bodies``, ``poses``); ``members``: an
#: ensemble of that many seeds (its rows' field ``ensemble``), or 1: one network (trained with the plan's seeds, each
#: apart, like Table 1's). key → (name, draws, members).
MORE_BODIES = {
    "bodies-shape": ("OperatorNet ours, a body per shape (Int+Ext)", {"bodies": "shape"}, 1),
    "bodies-shape-poses-quarter": (
        "OperatorNet ours, a body per shape, more random poses, an ensemble of 2 (Int+Ext)",
        {"bodies": "shape", "poses": "quarter"},
        2,
    ),
}


def bodies_group(bodies: str, poses: str = "sequence") -> str:
    """The :class:`~opnet.experiments.spec.RunSpec` group of a run trained on ``load_collection(..., bodies=, poses=)``:
    ``"bodies-<bodies>"``, then ``"-poses-<poses>"`` unless the poses are the design's.
    """
    return f"bodies-{bodies}" + ("" if poses == "sequence" else f"-poses-{poses}")


def declare(budget: Budget, *, ablation_sets: dict | None = None, seeds: int = 1, ablation_grid: str = "full") -> Plan:
    """Every entry of a reproduction at ``budget``, in the order it runs, and its steps (:func:`select` keeps a
    reproduction's). ``ablation_sets``: the ablation's columns (default :data:`~opnet.experiments.plan.ABLATION_SETS`);
    ``ablation_grid``: :data:`~opnet.experiments.plan.ABLATION_GRIDS`; ``seeds``: each network of Table 1, the Comp
    rows and the ablation is trained with seeds ``0 … seeds−1`` (:attr:`RunSpec.seeds
    <opnet.experiments.spec.RunSpec.seeds>`; an ensemble's members keep theirs).
    """
    rep = dict(seeds=tuple(range(seeds))) if seeds > 1 else {}  # replicate trainings of each network
    entries = [
        Entry(
            key,
            name,
            spec("table1", budget, ch, variant=v, name=name, **rep),
            paper_row=row,
            other_meshes=key in ("int+ext", "ext"),
        )
        for key, (name, ch, v, row) in TABLE1_ROWS.items()
    ]
    entries += [
        Entry(
            "pointnet",
            "PointNet AE",
            spec("table1", budget, variant="pointnet", name="PointNet AE", **rep),
            part="applications",
        ),
        *(
            Entry(key, name, spec("table1", budget, variant=arch, name=name, **rep), part="points")
            for key, (name, arch) in POINT_VARIANTS.items()
        ),
        Entry(
            "nn",
            "Nearest neighbour (Int+Ext)",
            baseline="nearest_neighbour",
            paper_row="Nearest neighbour (Int+Ext)",
            fields=dict(channels=list(KINDS)),
        ),
        Entry("base-shape", "Base shape", baseline="base_shape"),
    ]
    comp = {"comp-int+ext": ("(Comp)(Int+Ext)", KINDS, "comp"), "comp-ext": ("(Comp)(Ext)", ("extrinsic",), "comp")}
    comp |= {
        "comp-half-ext": ("(Comp + 1k)(Ext)", ("extrinsic",), "half"),
        "comp-three-ext": ("(Comp + 5k + 1k)(Ext)", ("extrinsic",), "three"),
    }
    for key, (label, ch, data) in comp.items():
        name = f"OperatorNet {label}"
        group = "comp" if data == "comp" else f"comp-{data}"
        row = name if data == "comp" else None
        entries.append(
            Entry(
                key,
                name,
                spec(group, budget, ch, name=name, **rep),
                trained_on=data,
                part="maps",
                paper_row=row,
                other_meshes=True,
            )
        )
    name = f"OperatorNet, {LABELS_RESOLUTION}-vertex labels (Int+Ext)"  # the paper's appendix: finer labels
    entries.append(
        Entry(
            f"labels-{LABELS_RESOLUTION}",
            name,
            spec(f"labels-{LABELS_RESOLUTION}", budget, KINDS, name=name, **rep),
            trained_on="labels",
            part="maps",
            other_meshes=True,
            fields=dict(labels=LABELS_RESOLUTION),
        )
    )
    for key, (name, draws, members) in MORE_BODIES.items():  # an ensemble of `members` seeds, or one network
        first = spec(bodies_group(**draws), budget, KINDS, variant="ours", name=name, **(rep if members == 1 else {}))
        runs = (first, *(replace(first, seed=s, name=f"{name}, seed {s}") for s in range(1, members)))
        fields = dict(draws, **({"ensemble": members} if members > 1 else {}))
        entries.append(Entry(key, name, runs, draws=draws, part="bodies", fields=fields))
    refined = ("int+ext", "ours", *MORE_BODIES)
    by_key = {e.key: e for e in entries}
    entries += [
        Entry("geometric", "Geometric (A+E)", baseline="geometric", test_sets=REFINE_SETS, part="refine"),
        Entry(
            "funcchar",
            "FuncChar (Int+Ext)",
            baseline="funcchar",
            tested_on="offsets",
            test_sets=REFINE_SETS,
            part="refine",
            paper_row="FuncChar (Int+Ext)",
        ),
        Entry(
            "funcchar-int",
            "FuncChar (Int)",
            baseline="funcchar_int",
            test_sets=REFINE_SETS,
            part="refine",
            paper_row="FuncChar (Int)",
        ),
        Entry("sfl", "SfL (full Laplacian)", baseline="sfl", test_sets=REFINE_SETS, part="refine", paper_row="SfL"),
    ]
    entries += [
        Entry(f"{key}+refined", f"{by_key[key].name} + refinement", refines=key, test_sets=REFINE_SETS, part="refine")
        for key in refined
    ]
    entries += ablation_entries(budget, ablation_sets, seeds=seeds, grid=ablation_grid)
    return Plan(tuple(entries), (Step("discretisation", "maps"), Step("applications", "applications")))


def ablation_label(channels) -> str:
    """The ablation's name of a channel set (a column of its table): the paper's short name of a set of
    :data:`ABLATION_SETS` (in any order: ``"A+E"``), else :func:`~opnet.inner_products.channel_label` of its names
    (``"Area+my ip"``).
    """
    names = channel_names(channels)
    paper = next((k for k, v in ABLATION_SETS.items() if set(v) == set(names)), None)
    return channel_label(names) if paper is None else paper


def ablation_entries(budget: Budget, sets: dict | None = None, *, seeds: int = 1, grid: str = "full") -> list[Entry]:
    """The ablation's entries: each set of ``sets`` (label → channels; default
    :data:`~opnet.experiments.plan.ABLATION_SETS`) at each depth of :data:`ABLATION_DEPTHS` (``grid="full"``), or
    every set at depth 1 and ``A+E+C`` at every depth (``grid="cross"``: the cells the paper's ablation claims read,
    :data:`ABLATION_GRIDS`), trained ``budget.ablation_epochs`` epochs (with ``seeds`` seeds), evaluated on
    ``test``; its key is its first run's name.
    """
    if grid not in ABLATION_GRIDS:
        raise ValueError(f"grid must be one of {ABLATION_GRIDS}, got {grid!r}.")
    sets = ABLATION_SETS if sets is None else sets
    out = []
    for depth in ABLATION_DEPTHS:
        for label, channels in sets.items():
            if grid == "cross" and depth != 1 and label != "A+E+C":
                continue
            name = f"OperatorNet ({label}) depth {depth}"
            s = spec("ablation", budget, channels, depth, epochs=budget.ablation_epochs, name=name)
            key = f"ablation-{s.run_name.removeprefix('ablation-')}"  # the same key whatever the seeds
            out.append(
                Entry(
                    key,
                    name,
                    replace(s, seeds=tuple(range(seeds))) if seeds > 1 else s,
                    table="ablation",
                    test_sets=("test",),
                    part="ablation",
                )
            )
    return out


def select(plan: Plan, parts) -> Plan:
    """The entries and steps of ``plan`` whose part is in ``parts`` (``table1`` always), without a refinement whose
    refined entry is left out.
    """
    parts = {"table1", *parts}
    unknown = parts - set(PARTS)
    if unknown:
        raise ValueError(f"unknown parts {sorted(unknown)}; the parts are {PARTS}.")
    entries = [e for e in plan.entries if e.part in parts]
    kept = {e.key for e in entries}
    entries = [e for e in entries if e.refines is None or e.refines in kept]
    return Plan(tuple(entries), tuple(s for s in plan.steps if s.part in parts))


#: The paper's Table 1 rows (:data:`opnet.experiments.paper.PAPER_TABLE1`) → the fields of the entries that stand
#: beside them (:meth:`Entry.match_fields`): declared once, by the entries' ``paper_row``.
PAPER_ROWS = {e.paper_row: e.match_fields() for e in declare(BUDGETS["quick"]).entries if e.paper_row}
#: The entries measured on at most ``Budget.refine_shapes`` shapes of each test set (the ``refine`` part: the
#: operator-matching baselines, SfL and the refinements), by key.
SUBSET_ENTRIES = frozenset(e.key for e in declare(BUDGETS["quick"]).entries if e.part == "refine")
