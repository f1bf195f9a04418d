"""Command-line options generated from a frozen config dataclass (``TrainConfig``, ``ReproduceConfig``,
``EvaluateConfig``): each field's metadata says how ``argparse`` exposes it (:func:`option`), :func:`add_arguments`
adds them to a parser and :func:`config_from_args` builds the config back.

- the flag: default ``--`` and the field's name with dashes; a ``bool`` field whose default is ``True`` becomes
  ``--no-<name>`` (it turns it off); one whose default is ``None`` (decided later, e.g. by the collection's profile)
  (``switch=True``: a ``bool | None`` field), becomes ``--no-<name>`` setting it to ``False``;
- ``type`` (argparse converts the text with it), ``choices``, ``help``; ``append``: a repeatable option collected into
  a tuple; ``required``: the option must be given; ``cli=False``: no flag (the field is set from Python only).
"""

from __future__ import annotations

import argparse
import dataclasses

__all__ = ["option", "positive_int", "cli_fields", "add_arguments", "config_from_args"]


def positive_int(text: str) -> int:
    """``text`` as an integer >= 1, for argparse (an ``ArgumentTypeError`` otherwise)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def option(
    default,
    help: str,
    *,
    flag=None,
    type=None,
    choices=None,
    cli: bool = True,
    append: bool = False,
    switch: bool = False,
    required: bool = False,
):
    """A config field with its command-line option described in its metadata (see the module's docstring)."""
    meta = dict(
        help=help, flag=flag, type=type, choices=choices, cli=cli, append=append, switch=switch, required=required
    )
    if isinstance(default, (list, dict, set)):
        raise TypeError("a config field's default must be immutable (a tuple, not a list).")
    return dataclasses.field(default=default, metadata=meta)


def cli_fields(config_cls) -> list[dataclasses.Field]:
    """The fields of ``config_cls`` that have a command-line option."""
    return [f for f in dataclasses.fields(config_cls) if f.metadata.get("cli", False)]


def _flag(f: dataclasses.Field) -> str:
    if f.metadata["flag"]:
        return f.metadata["flag"]
    name = f.name.replace("_", "-")
    return f"--no-{name}" if f.default is True or f.metadata["switch"] else f"--{name}"


def add_arguments(parser: argparse.ArgumentParser, config_cls) -> None:
    """Add an option to ``parser`` for each field of ``config_cls`` that has one; each stores into the field's name."""
    for f in cli_fields(config_cls):
        meta = f.metadata
        if f.default is True:
            parser.add_argument(_flag(f), dest=f.name, action="store_false", help=meta["help"])
            continue
        if f.default is False:
            parser.add_argument(_flag(f), dest=f.name, action="store_true", help=meta["help"])
            continue
        if f.metadata["switch"]:  # None: decided later; the flag turns it off
            parser.add_argument(
                _flag(f), dest=f.name, action="store_const", const=False, default=None, help=meta["help"]
            )
            continue
        options = dict(dest=f.name, help=meta["help"])
        if meta["required"]:
            options["required"] = True
        if meta["append"]:
            options.update(action="append", default=None)
        else:
            options["default"] = f.default
        if meta["flag"] and meta["choices"] is None:  # shown as the flag says, not as the field's name
            options["metavar"] = meta["flag"].lstrip("-").replace("-", "_").upper()
        if meta["type"] is not None:
            options["type"] = meta["type"]
        if meta["choices"] is not None:
            options["choices"] = list(meta["choices"])
        parser.add_argument(_flag(f), **options)


def config_from_args(config_cls, args: argparse.Namespace, **overrides):
    """The ``config_cls`` of a namespace parsed by a parser given :func:`add_arguments` (``overrides``: fields set
    otherwise); checked as any other config.
    """
    values = {}
    for f in cli_fields(config_cls):
        value = getattr(args, f.name)
        if f.metadata["append"]:
            value = f.default if value is None else tuple(value)
        values[f.name] = value
    return config_cls(**{**values, **overrides})
