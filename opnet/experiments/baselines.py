"""The baselines of the reproduction, registered by key: each builds an :class:`opnet.evaluate.Method` whose rows carry
``baseline=<key>``.

A builder is ``build(collection, budget, device) → Method`` (``budget``: the reproduction's
:class:`~opnet.experiments.plan.Budget`); a plan entry names its baseline by key
(:class:`~opnet.experiments.plan.Entry`). A baseline of one's own is one call::

    @opnet.experiments.register_baseline("centroid")
    def centroid(collection, budget, device):
        return opnet.evaluate.Method("Mean training shape", ..., info=dict(baseline="centroid"))
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

from ..evaluate import (
    Method,
    base_shape_method,
    geometric_method,
    nearest_neighbour_method,
    refined_method,
    sfl_method,
)
from ..shape_difference import KINDS

__all__ = [
    "BASELINES",
    "register_baseline",
    "baseline_method",
    "REFINE",
    "FUNCCHAR",
    "FUNCCHAR_INT",
    "refine_options",
]

#: The operator-matching settings of the refinement rows and the geometric baseline (:func:`opnet.reconstruct`),
#: chosen on ``val`` (the docs' results page).
REFINE = dict(channels=("area", "extrinsic"), optimizer="lbfgs", smoothness=1.0)
#: FuncChar's channels (Corman et al. 2017): the area and conformal operators of the shape and of its offset surface
#: (:class:`opnet.inner_products.OffsetAreaInnerProduct`, ``OffsetConformalInnerProduct``).
FUNCCHAR = ("area", "conformal", "offset_area", "offset_conformal")
#: FuncChar's purely intrinsic version (the paper's "FuncChar (Int)" row): the shape's own area and conformal
#: operators, at the same truncation.
FUNCCHAR_INT = ("area", "conformal")

#: key → builder ``(collection, budget, device) → Method``.
BASELINES: dict[str, Callable] = {}


def register_baseline(key: str, build: Callable | None = None, *, replace: bool = False):
    """Register ``build`` under ``key`` (usable as a decorator: ``@register_baseline("mine")``)."""

    def add(fn):
        if not callable(fn):
            raise TypeError(f"a baseline is a function (collection, budget, device) -> Method, got {fn!r}.")
        if key in BASELINES and not replace:
            raise ValueError(f"a baseline {key!r} is registered already; pass replace=True to overwrite it.")
        BASELINES[key] = fn
        return fn

    return add if build is None else add(build)


def baseline_method(key: str, collection, budget, device="cpu"):
    """The :class:`~opnet.evaluate.Method` of the baseline ``key`` on ``collection``, its rows carrying
    ``baseline=key``.
    """
    if key not in BASELINES:
        raise ValueError(f"unknown baseline {key!r}; registered: {sorted(BASELINES)} (register_baseline adds one).")
    method = BASELINES[key](collection, budget, device)
    if not isinstance(method, Method):
        raise TypeError(f"the baseline {key!r} built a {type(method).__name__}, not an opnet.evaluate.Method.")
    return replace(method, info={**method.info, "baseline": key})


def refine_options(budget, device) -> dict:
    """The :func:`opnet.reconstruct` options of the refinement rows and the geometric baseline at ``budget``."""
    return dict(REFINE, steps=budget.refine_steps, max_shapes=budget.refine_shapes, device=device)


def _nearest_neighbour(collection, budget, device):
    return nearest_neighbour_method(collection, KINDS)


def _base_shape(collection, budget, device):
    return base_shape_method(collection)


def _geometric(collection, budget, device):
    return geometric_method(collection, **refine_options(budget, device))


def _funcchar(collection, budget, device, channels=FUNCCHAR, name="FuncChar (Int+Ext)"):
    """FuncChar (Int+Ext): :func:`opnet.reconstruct` from the base shape matching the :data:`FUNCCHAR` operators
    (``collection`` must hold them: ``collection.with_channels([*collection.channels, "offset_area",
    "offset_conformal"])``), with :data:`REFINE`'s optimiser and smoothness; ``channels=FUNCCHAR_INT``: FuncChar
    (Int), the area and conformal operators alone.

    Corman et al. 2017 match the same operators (a shape's area and conformal shape differences, and its offset
    surface's), truncated as here. The solver is this project's, not theirs: L-BFGS on the vertices from the base
    shape, with :data:`REFINE`'s Dirichlet smoothness term.
    """
    missing = [c for c in channels if c not in collection.channels]
    if missing:
        raise ValueError(
            f"{name} matches the channels {channels}; this collection lacks {missing}: pass "
            f"coll.with_channels([*coll.channels, {', '.join(map(repr, missing))}])."
        )
    options = dict(refine_options(budget, device), channels=channels)
    return refined_method(base_shape_method(collection), collection, name=name, info={}, **options)


def _funcchar_int(collection, budget, device):
    """FuncChar (Int): :func:`_funcchar` on :data:`FUNCCHAR_INT`."""
    return _funcchar(collection, budget, device, FUNCCHAR_INT, "FuncChar (Int)")


def _sfl(collection, budget, device):
    """Shape-from-Laplacian (:func:`opnet.evaluate.sfl_method`) on as many shapes as the refinement rows."""
    return sfl_method(collection, max_shapes=budget.refine_shapes, device=device)


register_baseline("nearest_neighbour", _nearest_neighbour)
register_baseline("base_shape", _base_shape)
register_baseline("geometric", _geometric)
register_baseline("funcchar", _funcchar)
register_baseline("funcchar_int", _funcchar_int)
register_baseline("sfl", _sfl)
