"""The hyper-parameters of a training run: :class:`TrainConfig`, its checks, and the ``python -m opnet train``
options generated from its fields.

Each field of :class:`TrainConfig` is an argument of :func:`opnet.train.fit` (same name, same default). Its
metadata says how the command line exposes it: the flag (default ``--`` and the name with dashes), the ``type``
argparse converts the text with, the ``choices`` and the ``help`` text; a field marked ``cli=False`` has no flag.
A ``bool`` field whose default is ``True`` becomes a ``--no-...`` flag that turns it off.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass

from .. import options as cli_options
from .._checks import check_int, check_number, is_integer
from ..devices import resolve_device  # re-exported: opnet.train.config.resolve_device as before
from ..inner_products import get_inner_product, split_channels
from ..model import ARCHITECTURES, VARIANTS
from ..options import option, positive_int
from ..shape_difference import CHANNEL_SETS, KINDS

__all__ = [
    "TrainConfig",
    "add_arguments",
    "config_from_args",
    "parse_channels",
    "resolve_device",
    "positive_int",
    "SCHEDULES",
    "DEPTHS",
]

#: The learning-rate schedules of :func:`opnet.train.fit`: a constant rate (the paper's code's), or one cycle
#: (our variant's).
SCHEDULES = ("constant", "onecycle")
#: The encoder depths of OperatorNet (the paper's ablation).
DEPTHS = (1, 2, 3, 4)
_VARIANT_SCHEDULE = {"paper": "constant", "ours": "onecycle"}
#: The number of vertices the PointNet encoder reads when ``n_points`` is not given.
DEFAULT_POINTS = 256


def parse_channels(channels, collection=None) -> tuple[str, ...]:
    """``"area,extrinsic"``, ``"A+E"`` (:data:`opnet.CHANNEL_SETS`), ``"module:Class"`` or a sequence of channels.

    Parameters
    ----------
    channels : str or sequence
        Channel names, inner products, a comma-separated list of them or a short name of
        :data:`opnet.CHANNEL_SETS`.
    collection : opnet.data.Collection, optional
        With it, a name it holds needs no registration and an instance must match what it recorded
        (:meth:`~opnet.data.storage.Collection.channel_names`).

    Returns
    -------
    tuple of str
        The channel names, in the order given.
    """
    if collection is not None:
        return collection.channel_names(channels)
    channels = tuple(get_inner_product(c).name for c in split_channels(channels))
    if not channels or len(set(channels)) != len(channels):
        raise ValueError(
            f"channels must be one or more channels without repeats (e.g. {KINDS}, or one of "
            f"{list(CHANNEL_SETS)}), got {channels!r}."
        )
    return channels


_VARIANT_HELP = (
    "paper: the paper's network; ours: standardised inputs, a displacement from the base and a one-cycle learning "
    "rate (docs/results.md, 'Our variant')"
)
_ARCHITECTURE_HELP = (
    "operatornet (default), or a point-set autoencoder that reads the coordinates (same decoder, loss and "
    "checkpoints; --channels/--variant do not apply): pointnet (the paper's PointNet baseline, no spatial "
    "transformer), pointnet_stn (with its input transform) or pointnet2 (PointNet++)"
)


@dataclass(frozen=True)
class TrainConfig:
    """The hyper-parameters of :func:`opnet.train.fit` (the network, the optimisation, the device), checked.

    Every field is the argument of :func:`~opnet.train.fit` of the same name, with the same default and meaning
    (see there). Building one runs the checks :func:`~opnet.train.fit` runs on them (a ``ValueError`` with the same
    message); the channels are checked against the collection later (:meth:`channel_names`).

    Attributes
    ----------
    channels : channels or str, optional
        Input operators (default all of the collection's).
    depth : int
        Encoder depth, 1 to 4.
    epochs, batch_size : int
        Passes over the training split; shapes per optimiser step (global under ``torchrun``).
    lr : float
        Adam's (peak) learning rate.
    operator_noise : float
        Gaussian noise added to each training input, per entry this many times the entry's standard deviation over the
        training operators (OperatorNet only); 0 (default): none.
    seed : int
        Initialisation and shuffling.
    hidden : int
        Width of the hidden dense layers.
    subtract_identity : bool
        The network sees ``D − I``.
    variant : str
        ``"paper"`` or ``"ours"`` (:data:`opnet.model.VARIANTS`).
    schedule : str, optional
        ``"constant"`` or ``"onecycle"`` (default: the variant's, :attr:`lr_schedule`).
    standardize, residual : bool, optional
        Override the variant's network options.
    architecture : str
        ``"operatornet"``, or a point-set autoencoder (:data:`opnet.model.ARCHITECTURES`): ``"pointnet"``,
        ``"pointnet_stn"``, ``"pointnet2"``.
    n_points : int, optional
        Vertices the PointNet encoder reads (default 256, :attr:`points`).
    device : str
        ``"auto"``, ``"cpu"``, ``"cuda"``, ``"cuda:N"``.
    checkpoint_every : float
        Seconds between a run directory's checkpoints (the last epoch is always written); not a setting of the run.
    """

    channels: object = option(
        None,
        "input operators, comma-separated: built-in (area, conformal, extrinsic), registered, or your own "
        "inner product as package.module:Class (imported, and added to the collection, cached beside it); or a "
        "short name (A+E+C, Area, Ext, Conf, A+E, A+C, E+C); default all of the collection's (OperatorNet only)",
    )
    depth: int = option(1, "convolution layers in OperatorNet's encoder (1)", type=int, choices=DEPTHS)
    epochs: int = option(50, "passes over the training split (50); more continues a run", type=positive_int)
    batch_size: int = option(32, "shapes per step, global across processes (32)", type=positive_int)
    lr: float = option(1e-3, "Adam learning rate (1e-3)", type=float)
    operator_noise: float = option(
        0.0,
        "Gaussian noise on the training operators, in units of each entry's standard deviation over the training "
        "set (meant to model a computed map's error); 0, the default, is none",
        type=float,
    )
    seed: int = option(0, "initialisation and shuffling seed (0)", type=int)
    hidden: int = option(1024, "width of the two hidden dense layers (1024)", type=positive_int)
    subtract_identity: bool = option(True, "feed the network D instead of D - I (the default subtracts the identity)")
    variant: str = option("paper", _VARIANT_HELP, choices=tuple(VARIANTS))
    schedule: str | None = option(
        None, "learning rate over the run (default: constant for paper, onecycle for ours)", choices=SCHEDULES
    )
    standardize: bool | None = option(None, "override the variant's input standardisation", cli=False)
    residual: bool | None = option(None, "override the variant's displacement from the base", cli=False)
    architecture: str = option("operatornet", _ARCHITECTURE_HELP, choices=tuple(ARCHITECTURES))
    n_points: int | None = option(
        None, "pointnet: vertices the encoder reads (256)", flag="--points", type=positive_int
    )
    device: str = option("auto", "auto (CUDA if present), cpu, cuda, cuda:N")
    checkpoint_every: float = option(
        30.0, "seconds between checkpoints of a run directory (30); its last epoch is always written", type=float
    )

    def __post_init__(self):
        """Refuse bad values with the messages of :func:`opnet.train.fit`, in the order it checks them."""
        if self.architecture not in ARCHITECTURES:
            raise ValueError(f"architecture must be one of {list(ARCHITECTURES)}, got {self.architecture!r}.")
        if self.pointnet and (
            self.channels is not None
            or self.variant != "paper"
            or self.standardize is not None
            or self.residual is not None
            or self.depth != 1
            or self.subtract_identity is not True
            or self.operator_noise
        ):
            raise ValueError(
                f"architecture={self.architecture!r} reads coordinates, not operators: channels, depth, variant, "
                "subtract_identity, standardize, residual and operator_noise are OperatorNet's options; leave them "
                "unset."
            )
        if not self.pointnet and self.n_points is not None:
            raise ValueError(
                "n_points is the PointNet autoencoders' option (architecture 'pointnet', 'pointnet_stn' or "
                "'pointnet2'); OperatorNet reads "
                "operators, not points: leave it unset."
            )
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {list(VARIANTS)}, got {self.variant!r}.")
        if self.lr_schedule not in SCHEDULES:
            raise ValueError(f"schedule must be one of {SCHEDULES}, got {self.schedule!r}.")
        for name in ("epochs", "batch_size", "hidden"):
            check_int(name, getattr(self, name))
        if not (is_integer(self.seed) and 0 <= self.seed < 2**63):
            raise ValueError(f"seed must be an integer from 0 to 2**63 - 1, got {self.seed!r}.")
        object.__setattr__(self, "seed", int(self.seed))  # a numpy integer: the run of the same Python int
        every = self.checkpoint_every
        if isinstance(every, bool) or not (isinstance(every, (int, float)) and every >= 0):
            raise ValueError(
                f"checkpoint_every must be a number of seconds >= 0 (0: after every epoch), got "
                f"{self.checkpoint_every!r}."
            )
        check_int("n_points", self.points)
        check_number("lr", self.lr)
        noise = self.operator_noise
        if isinstance(noise, bool) or not (isinstance(noise, (int, float)) and 0 <= noise < float("inf")):
            raise ValueError(f"operator_noise must be a number >= 0 (0: none), got {noise!r}.")
        resolve_device(self.device)
        if self.depth not in DEPTHS:  # OperatorNet's own check, made before any data is read
            raise ValueError(
                f"depth must be 1, 2, 3 or 4 convolution layers (the paper's ablation), got {self.depth!r}."
            )

    @property
    def pointnet(self) -> bool:
        """Whether the network reads the shapes' coordinates (the PointNet autoencoder) rather than operators."""
        return ARCHITECTURES[self.architecture][1] == "vertices"

    @property
    def lr_schedule(self) -> str:
        """:attr:`schedule`, or the variant's when it is ``None`` (``"constant"`` for paper, ``"onecycle"`` ours)."""
        return _VARIANT_SCHEDULE[self.variant] if self.schedule is None else self.schedule

    @property
    def points(self) -> int:
        """:attr:`n_points`, or 256 when it is ``None``."""
        return DEFAULT_POINTS if self.n_points is None else self.n_points

    def channel_names(self, collection) -> tuple[str, ...]:
        """The names of the channels the network reads from ``collection`` (``()`` for the PointNet autoencoder).

        Parameters
        ----------
        collection : opnet.data.Collection
            The collection trained on; :attr:`channels` ``None`` means all of its channels.

        Returns
        -------
        tuple of str
            In the order asked (:meth:`~opnet.data.storage.Collection.channel_names`, which refuses a channel it
            does not hold).
        """
        if self.pointnet:
            return ()
        return collection.channel_names(collection.channels if self.channels is None else self.channels)

    def as_kwargs(self) -> dict:
        """The fields as keyword arguments of :func:`opnet.train.fit` (values as they are, not copied)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add an option to ``parser`` for each field of :class:`TrainConfig` that has one (``cli`` in its metadata).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The ``train`` sub-command's parser. Each option stores into the field's name, with the field's default;
        a ``bool`` field whose default is ``True`` becomes ``--no-<name>`` (``store_false``).
    """
    cli_options.add_arguments(parser, TrainConfig)


def config_from_args(args: argparse.Namespace, **overrides) -> TrainConfig:
    """The :class:`TrainConfig` of a namespace parsed by a parser given :func:`add_arguments`.

    Parameters
    ----------
    args : argparse.Namespace
        Holds one attribute per exposed field (other attributes are ignored).
    **overrides
        Fields to set otherwise (e.g. ``channels`` resolved against the collection, or those without a flag).

    Returns
    -------
    TrainConfig
        Checked as any other (a ``ValueError`` with :func:`opnet.train.fit`'s message for a bad value).
    """
    return cli_options.config_from_args(TrainConfig, args, **overrides)
