"""Declared runs: :class:`RunSpec`, one network to train (what it reads, its architecture, its budget), and the
run directory it lives in.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field, replace
from numbers import Real
from pathlib import Path

from .._checks import is_integer
from ..inner_products import (
    INNER_PRODUCTS,
    channel_digest,
    channel_label,
    channel_names,
    get_inner_product,
    known_inner_products,
    split_channels,
)
from ..shape_difference import CHANNEL_SETS, KINDS

__all__ = ["RunSpec", "VARIANTS", "ARCHITECTURES", "POINT_LABELS"]

#: The network variants a spec may ask for (:data:`opnet.model.VARIANTS`).
VARIANTS = ("paper", "ours")
#: What a spec may train: OperatorNet (reads operators) or a point-set autoencoder (reads coordinates): PointNet
#: without its spatial transformer (the paper's comparisons), with it, and PointNet++
#: (:data:`opnet.model.ARCHITECTURES`).
ARCHITECTURES = ("operatornet", "pointnet", "pointnet_stn", "pointnet2")
#: The point-set autoencoders' display names in tables (never parsed: rows carry ``architecture``).
POINT_LABELS = {"pointnet": "PointNet AE", "pointnet_stn": "PointNet AE (transformer)", "pointnet2": "PointNet++ AE"}


@dataclass(frozen=True)
class RunSpec:
    """One network to train, as data: the arguments of :func:`opnet.train.fit` that define it.

    Parameters
    ----------
    channels : the operators it reads (names, inner products of your own, or a short name such as ``"A+E"``);
        ``()`` for a point-set autoencoder.
    depth : OperatorNet's encoder depth (1–4).
    variant : ``"paper"`` or ``"ours"`` (:data:`opnet.model.VARIANTS`).
    architecture : ``"operatornet"``, or a point-set autoencoder: ``"pointnet"`` (PointNet without its spatial
        transformer, the paper's), ``"pointnet_stn"`` (with it) or ``"pointnet2"`` (PointNet++).
    epochs, batch_size, lr, hidden, seed : the budget and the seed (:func:`opnet.train.fit`).
    schedule : the learning rate over the run (:data:`opnet.train.SCHEDULES`; default ``None``: the variant's), checked
        by :class:`opnet.train.TrainConfig` when the run's folder is named or trained.
    seeds : the seeds of replicate trainings of the same network (e.g. ``(0, 1, 2)``; default: ``seed`` alone); each
        is a run of its own (:meth:`replicates`), and their rows are summarised with intervals
        (:mod:`opnet.experiments.stats`).
    group : the prefix of its run directory (``"table1"``, ``"ablation"``, ...).
    name : its display name in tables (default ``"OperatorNet (<channels>)"``, with the depth when not 1).
    options : other options of :func:`opnet.train.fit` (e.g. ``{"standardize": True}``).
    """

    channels: tuple = KINDS
    depth: int = 1
    variant: str = "paper"
    architecture: str = "operatornet"
    epochs: int = 50
    batch_size: int = 32
    lr: float = 1e-3
    hidden: int = 1024
    seed: int = 0
    schedule: str | None = None
    seeds: tuple = ()
    group: str = "run"
    name: str | None = None
    options: dict = field(default_factory=dict, hash=False)

    def __post_init__(self):
        if self.architecture not in ARCHITECTURES:
            raise ValueError(f"architecture must be one of {ARCHITECTURES}, got {self.architecture!r}.")
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {VARIANTS}, got {self.variant!r}.")
        channels = split_channels(self.channels)
        # names stay names (a collection resolves them); classes and "module:Class" become inner products
        channels = tuple(c if isinstance(c, str) and ":" not in c else get_inner_product(c) for c in channels)
        if self.reads_points and channels not in ((), KINDS):
            raise ValueError(f"a {self.architecture} run reads coordinates, not operators: leave channels=().")
        if self.architecture == "operatornet" and not channels:
            raise ValueError("an operatornet run needs channels (e.g. ('area', 'extrinsic')).")
        object.__setattr__(self, "channels", () if self.reads_points else channels)
        if isinstance(self.seeds, int) and not isinstance(self.seeds, bool) and self.seeds >= 1:
            raise TypeError(
                f"seeds lists the seeds, e.g. (0, 1, 2) (tuple(range({self.seeds})) for {self.seeds} of them)."
            )
        try:
            seeds = tuple(self.seeds)
        except TypeError:
            raise ValueError(f"seeds must be distinct integers >= 0, e.g. (0, 1, 2), got {self.seeds!r}.") from None
        if (
            isinstance(self.seeds, str)
            or not all(is_integer(s) and 0 <= s < 2**63 for s in seeds)
            or len(set(seeds)) != len(seeds)
        ):
            raise ValueError(f"seeds must be distinct integers >= 0, e.g. (0, 1, 2), got {self.seeds!r}.")
        if seeds and self.seed != 0:
            raise ValueError(f"give seed={self.seed} or seeds={seeds}, not both (seeds lists every seed to train).")
        object.__setattr__(self, "seeds", tuple(map(int, seeds)))
        if self.schedule is not None and not isinstance(self.schedule, str):  # its name: TrainConfig checks it
            raise ValueError(f"schedule must be None (the variant's) or a schedule's name, got {self.schedule!r}.")
        if not re.fullmatch(r"[A-Za-z0-9_.+-]+", self.group):
            raise ValueError(f"group must be a folder-name prefix (letters, digits, _ . + -), got {self.group!r}.")

    @property
    def reads_points(self) -> bool:
        """Whether it trains a point-set autoencoder (it reads the shapes' coordinates) rather than OperatorNet."""
        return self.architecture != "operatornet"

    @property
    def channel_names(self) -> tuple[str, ...]:
        """The names of :attr:`channels`, in order."""
        return channel_names(self.channels)

    @property
    def label(self) -> str:
        """The display name (:attr:`name` when given): for tables and figures, never parsed."""
        if self.name is not None:
            return self.name
        if self.reads_points:
            return POINT_LABELS[self.architecture]
        ours = " ours" if self.variant == "ours" else ""
        depth = f" depth {self.depth}" if self.depth != 1 else ""
        return f"OperatorNet{ours} ({channel_label(self.channels)}){depth}"

    @property
    def run_name(self) -> str:
        """The run directory's name: ``<group>-<channels>-d<depth>[-<variant>]`` (``<group>-<architecture>`` for a
        point-set autoencoder).

        Built-in channels in the order of a short name of :data:`opnet.CHANNEL_SETS` go by it (``A+E+C``, ``Ext``:
        the folders reproduce always used), in another order by their names (``extrinsic+area``: the channel order
        is the network's input order, so another network); a set with channels of your own by their names and a
        digest of their implementations, so that editing a class trains a new run instead of resuming one of the old
        code. A seed other than 0 and extra options add ``-s<seed>`` and a digest of the options. A spec of several
        :attr:`seeds` names its replicates' runs joined by ``+``.
        """
        if self.seeds:
            return "+".join(r.run_name for r in self.replicates())
        if self.reads_points:
            stem = f"{self.group}-{self.architecture}"
        else:
            names = self.channel_names
            short = next((k for k, v in CHANNEL_SETS.items() if v == names), None)
            if short is None and all(isinstance(c, str) and c in INNER_PRODUCTS for c in self.channels):
                short = "+".join(names)  # built-ins in another order than the short name's: another network
            if short is None:
                own = [c for c in self.channels if not (isinstance(c, str) and c in INNER_PRODUCTS)]
                known = known_inner_products()  # a name of one's own that is not registered: by its name alone
                codes = [c if isinstance(c, str) and c not in known else channel_digest(c) for c in own]
                digest = hashlib.sha256("".join(codes).encode()).hexdigest()[:8]
                short = "+".join(re.sub(r"[^A-Za-z0-9_-]+", "_", n) for n in names) + f"-{digest}"
            stem = f"{self.group}-{short}-d{self.depth}" + ("" if self.variant == "paper" else f"-{self.variant}")
        if self.seed != 0:
            stem += f"-s{self.seed}"
        if self.options:  # a number by its value: {"operator_noise": 1} is the run of 1.0
            canon = {
                k: float(v) if isinstance(v, Real) and not isinstance(v, bool) else v for k, v in self.options.items()
            }
            stem += "-" + hashlib.sha256(repr(sorted(canon.items())).encode()).hexdigest()[:8]
        return stem

    def replicates(self) -> tuple:
        """One spec per seed of :attr:`seeds` (``seed`` set, ``seeds`` empty), or ``(self,)`` for one seed."""
        if not self.seeds:
            return (self,)
        return tuple(replace(self, seed=s, seeds=()) for s in self.seeds)

    def run_id(self, collection) -> str:
        """The name of its run's folder: :attr:`run_name`, then ``-`` and :func:`opnet.train.run_digest` of its
        :meth:`fit_options` on ``collection`` (everything that sets its weights: settings, data, channel digests), so
        that a changed budget, collection or channel never meets an old run. Rows record it in their ``provenance``.
        """
        from ..train import run_digest

        return f"{self.run_name}-{run_digest(collection, **self.fit_options())}"

    def run_dir(self, root, collection) -> Path | None:
        """``root / run_id(collection)`` (``None`` when ``root`` is ``None``: trained in memory, nothing written)."""
        return None if root is None else Path(root) / self.run_id(collection)

    def fit_options(self) -> dict:
        """The keyword arguments of :func:`opnet.train.fit` this spec stands for (without the collection); a spec
        of several :attr:`seeds` trains one run per seed (:meth:`replicates`), so it has none.
        """
        if self.seeds:
            raise ValueError(f"{self.label} declares the seeds {self.seeds}: train each of spec.replicates().")
        common = dict(epochs=self.epochs, batch_size=self.batch_size, lr=self.lr, hidden=self.hidden, seed=self.seed)
        if self.schedule is not None:
            common["schedule"] = self.schedule
        if self.reads_points:
            return dict(common, architecture=self.architecture, **self.options)
        return dict(common, channels=list(self.channels), depth=self.depth, variant=self.variant, **self.options)

    def fields(self) -> dict:
        """The structured fields every row of this run carries: ``run``, ``architecture``, ``variant``, ``channels``
        (names), ``depth`` and ``group``.
        """
        return dict(
            run=self.run_name,
            architecture=self.architecture,
            variant=self.variant,
            channels=list(self.channel_names),
            depth=self.depth if self.architecture == "operatornet" else None,
            group=self.group,
        )

    def refined_fields(self) -> dict:
        """The fields of this network's output refined by :func:`opnet.reconstruct`: :meth:`fields` without
        ``channels`` (the refinement's channels are its rows' own) and with ``refined=True``.
        """
        return {**{k: v for k, v in self.fields().items() if k != "channels"}, "refined": True}
