"""The steps of the plan that are not one method each: the test shapes given on other triangulations
(:func:`discretisation_rows`) and the ground-truth analogy and interpolation benchmarks (:func:`application_methods`,
:func:`applications_rows`), and the refinement curves the figures draw.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from .._checks import check_int
from ..apps import nan_stat
from ..data.profiles import profile_of
from ..evaluate import evaluate, evenly_spaced, operatornet_method, test_set_indices
from .baselines import REFINE
from .figures import application_figures, discretisation_figure
from .figures import refinement_curves as _curves
from .plan import POINT_VARIANTS
from .stats import summarize_seeds

__all__ = [
    "DISCRETISATIONS",
    "discretisation_indices",
    "discretisation_rows",
    "application_methods",
    "analogy_kinds",
    "applications_rows",
    "seeded_applications_rows",
    "PATH_METRICS",
    "refinement_curves",
]

#: The different-discretisation rows: test shapes on these meshes, mapped onto the 1k base by these maps.
DISCRETISATIONS = (("2k", "true"), ("2k", "computed"), ("5k", "true"), ("5k", "computed"))


def discretisation_indices(coll, budget) -> np.ndarray:
    """The ``test`` shapes of :func:`discretisation_rows`: at most ``budget.discretisation_shapes``, evenly spaced."""
    check_int("budget.discretisation_shapes", budget.discretisation_shapes)
    return evenly_spaced(test_set_indices(coll, "test"), budget.discretisation_shapes)


def _maps_of(mapped, coll, resolution: str, maps: str, k: int) -> bool:
    """Whether ``mapped`` is ``mapped_collection(coll, resolution, maps, k=k)`` (all of ``coll``'s shapes)."""
    meta, params = mapped.meta, mapped.params
    same_maps = (meta.get("map_resolution"), meta.get("maps"), meta.get("map_k")) == (resolution, maps, k)
    return (
        same_maps
        and len(mapped) == len(coll)
        and all(np.array_equal(params.get(key), coll.params.get(key)) for key in ("phenotypes", "controls"))
    )


def discretisation_rows(
    coll,
    nets: dict,
    budget,
    *,
    fields: dict | None = None,
    comp=None,
    data_root=None,
    progress=None,
    out=None,
    shown=(),
    extra: dict | None = None,
    funcchar: bool = False,
    device="cpu",
    labels: dict | None = None,
) -> list[dict]:
    """Reconstructions of test shapes given on other triangulations: rows with ``"table"`` ``"discretisation"``.

    At most ``budget.discretisation_shapes`` shapes of ``test`` (evenly spaced, :func:`discretisation_indices`) are
    generated on each mesh of :data:`~opnet.experiments.steps.DISCRETISATIONS` and mapped onto the base by the true or
    the computed map (:func:`opnet.data.mapped_collection`), and, as a reference, taken with their exact 1k operators
    (``resolution`` ``"1k"``, ``maps`` ``"exact"``). Every network of ``nets`` (name → network, or → its
    :class:`~opnet.experiments.runner.Run`, whose spec's fields its rows then carry) decodes every encoding; d_R, d_V,
    d_E against the generator's 1k shapes. Rows also hold ``resolution``, ``maps`` and ``map_error`` (metres,
    mean over the shapes; 0 for the true map) and ``fields[name]`` (a network's run fields: ``run``, ``architecture``,
    ``variant``, ``group``...). A decoder given as a list (of networks or runs, one per training seed) gets one row per
    encoding over its seeds (:func:`opnet.experiments.stats.summarize_seeds`: the mean, an interval over seeds and
    shapes). ``comp``: the collection through the 2k computed maps, whose maps are reused. With ``out``, writes
    ``discretisation.png`` there (:func:`discretisation_figure` of three 5k shapes, or as many as the budget maps, by
    the networks named in ``shown``, default all). ``funcchar``: also FuncChar (Int+Ext)'s geometric reconstruction of
    the 5k shapes through the computed maps (the paper's appendix, Fig. 12's bottom row; ``baseline`` ``"funcchar"``,
    at most ``budget.refine_shapes`` shapes, on ``device``), its four channels carried through maps of their own, and
    drawn in the figure beside the networks.
    ``labels``: name → the collection a network of ``nets`` was trained on when its labels are on another mesh
    (:func:`opnet.data.labels_collection` of ``coll``: the paper's network trained with 2k-vertex labels); it decodes
    the same encodings and is measured against those shapes on that mesh.
    """
    from ..data import mapped_collection
    from ..data.mapped import MAP_K

    idx = discretisation_indices(coll, budget)
    encodings = {("1k", "exact"): coll.subset(idx)}
    for res, maps in DISCRETISATIONS:
        if comp is not None and _maps_of(comp, coll, res, maps, MAP_K):
            encodings[res, maps] = comp.subset(idx)
        else:
            encodings[res, maps] = mapped_collection(coll, res, maps, indices=idx, root=data_root, progress=progress)
    decoders = {name: list(n) if isinstance(n, (list, tuple)) else [n] for name, n in nets.items()}
    rows, geometric = [], {}
    for (res, maps), c in encodings.items():
        error = float(np.mean(c.params["map_error"])) if "map_error" in c.params else 0.0
        where = dict(table="discretisation", resolution=res, maps=maps, map_error=error)
        for name, members in decoders.items():
            info = {**_run_fields(members[0]), **(fields or {}).get(name, {}), **where}
            on = _labelled(c, (labels or {}).get(name), idx)
            each = [
                evaluate(on, [operatornet_method(_network(m), on, name, info=info | _seed(m, members))], ("test",),
                         extra=extra, per_shape=True)[0]
                for m in members
            ]  # fmt: skip
            rows.append(summarize_seeds(each) if len(each) > 1 else each[0])  # the claims pair them
    if funcchar:  # Corman et al.'s reconstruction of the 5k inputs, beside the networks'
        from .baselines import FUNCCHAR, baseline_method

        c = mapped_collection(coll, "5k", "computed", indices=idx, root=data_root, progress=progress, channels=FUNCCHAR)
        method = baseline_method("funcchar", c, budget, device)
        if method.name in decoders:  # the figure draws both under their names
            raise ValueError(f"a network is named {method.name!r}, as FuncChar's row is: name it otherwise.")
        where = dict(
            table="discretisation", resolution="5k", maps="computed", map_error=float(np.mean(c.params["map_error"]))
        )
        method = replace(method, info={**method.info, **where})
        rows += evaluate(c, [method], ("test",), extra=extra, per_shape=True)
        geometric[method.name] = method  # drawn beside the networks (the same shapes, in the same order)
    if out is not None:
        names = [name for name in shown if name in decoders] or list(decoders)
        picked = {name: _network(decoders[name][0]) for name in names}  # a replicated one: its first seed
        fine = encodings["5k", "computed"]
        on = {name: _labelled(fine, lab, idx) for name, lab in (labels or {}).items() if name in picked}
        plotter = discretisation_figure(fine, picked | geometric, labels=on)
        Path(out).mkdir(parents=True, exist_ok=True)
        plotter.screenshot(str(Path(out) / "discretisation.png"))
        plotter.close()
    return rows


def _labelled(encoded, labels, idx):
    """``encoded`` (shapes ``idx`` of a collection, with their operators) with the vertices and faces of ``labels``
    (:func:`opnet.data.labels_collection` of that collection: the same shapes on another mesh), or as it is.
    """
    if labels is None:
        return encoded
    params = encoded.params
    if "labels_resolution" not in labels.meta or not all(
        np.array_equal(labels.params[k][idx], params[k]) for k in ("phenotypes", "controls")
    ):
        raise ValueError("labels must be opnet.data.labels_collection of the collection whose shapes are decoded.")
    meta = dict(encoded.meta, labels_resolution=labels.meta["labels_resolution"])
    out = replace(encoded, vertices=labels.vertices[idx], faces=labels.faces, meta=meta)
    out._instances.update(encoded._instances)
    return out


def _is_run(member) -> bool:
    """Whether a decoder is given as its :class:`~opnet.experiments.runner.Run` (else as a bare network)."""
    return hasattr(member, "spec") and hasattr(member, "net")


def _network(member):
    """The network of a decoder given as a network or as its run."""
    return member.net if _is_run(member) else member


def _run_fields(member) -> dict:
    """A run's spec fields (none for a bare network)."""
    return member.spec.fields() if _is_run(member) else {}


def _seed(member, members) -> dict:
    """The seed and run of one of several trainings of a decoder (its rows are then summarised over them)."""
    if len(members) == 1 or not _is_run(member):
        return {}
    return dict(seed=member.spec.seed, run=member.spec.run_name)


def application_methods(coll, runs: dict, budget, *, refine: bool = True, device="cpu") -> list:
    """The applications' methods (:class:`opnet.apps.ShapeAlgebra`): the paper's OperatorNet (Int+Ext) with the
    multiplicative and the linear algebra, our variant, the first + refinement
    (:data:`~opnet.experiments.baselines.REFINE`, at most ``budget.apps_refine_shapes`` shapes per kind), the PointNet
    AE (and the other point-set autoencoders of :data:`~opnet.experiments.plan.POINT_VARIANTS` that ``runs`` holds) and
    NN. ``runs``: the plan's entry keys (``"int+ext"``, ``"ours"``, ``"pointnet"``, ...) → their
    :class:`~opnet.experiments.runner.Run`. Each method carries its run's structured fields and the plan's ``entry``
    (:attr:`opnet.apps.ShapeAlgebra.fields`; ``refined`` for the refined one), NN ``baseline`` ``"nearest_neighbour"``.
    """
    from .. import apps

    paper, ours = (runs[key] for key in ("int+ext", "ours"))
    fields = dict(paper.spec.fields(), entry="int+ext")
    methods = [
        apps.operatornet_algebra(paper.net, coll, fields=fields),
        apps.operatornet_algebra(paper.net, coll, scheme="linear", fields=fields),
        apps.operatornet_algebra(
            ours.net, coll, name="OperatorNet ours (mult.)", fields=dict(ours.spec.fields(), entry="ours")
        ),
    ]
    if refine:
        methods.append(
            apps.operatornet_algebra(
                paper.net,
                coll,
                refine=dict(REFINE, steps=budget.refine_steps, device=device),
                max_shapes=budget.apps_refine_shapes,
                fields=dict(paper.spec.refined_fields(), entry="int+ext+refined"),
            )
        )
    points = [key for key in ("pointnet", *POINT_VARIANTS) if key in runs]
    methods += [
        *(
            apps.pointnet_algebra(
                runs[key].net, coll, name=runs[key].spec.label, fields=dict(runs[key].spec.fields(), entry=key)
            )
            for key in points
        ),
        apps.nearest_neighbour_algebra(coll, fields=dict(baseline="nearest_neighbour", entry="nn")),
    ]
    return methods


def analogy_kinds(coll) -> tuple:
    """The analogy benchmark's kinds for ``coll``: those its profile names (:attr:`opnet.data.Profile.analogy_kinds`),
    else ``("pose", "body")``, which every generator gives ground truth for.
    """
    from ..apps import ANALOGY_KINDS

    named = tuple(k for k in profile_of(coll.meta.get("name")).analogy_kinds if k in ANALOGY_KINDS)
    return named or ("pose", "body")


def applications_rows(
    coll, methods, budget, *, out=None, progress=None, seed: int = 0, per_shape: bool = False
) -> list[dict]:
    """Run the ground-truth analogy (``budget.analogies`` questions per kind) and interpolation (``budget.paths``
    paths of 11 steps per kind) benchmarks of :mod:`opnet.apps`; rows get ``table`` ``"analogy"`` or
    ``"interpolation"`` and their method's fields (:func:`application_methods`). With ``out``, also writes
    ``interpolation_<kind>.png`` and ``analogy_<kind>.png`` there. ``seed`` draws the questions and paths;
    ``per_shape``: rows hold per-question and per-path values (:func:`opnet.apps.analogy_benchmark`).
    """
    from .. import apps

    quads = [apps.analogy_quadruples(coll, kind, budget.analogies, seed=seed) for kind in analogy_kinds(coll)]
    paths = [apps.interpolation_paths(coll, kind, budget.paths, seed=seed) for kind in apps.PATH_KINDS]
    each = dict(progress=progress, per_shape=per_shape)
    rows = [dict(r, table="analogy") for r in apps.analogy_benchmark(coll, methods, quads, **each)]
    rows += [dict(r, table="interpolation") for r in apps.interpolation_benchmark(coll, methods, paths, **each)]
    if out is not None:
        application_figures(Path(out), coll, methods, quads, paths)
    return [dict(r, preset=coll.meta.get("preset")) for r in rows]


def refinement_curves(coll, idx, inits: dict, steps: int, snapshot_steps=(), *, device="cpu") -> tuple[dict, dict]:
    """Run :func:`opnet.reconstruct` (settings :data:`~opnet.experiments.baselines.REFINE`) on shapes ``idx`` from each
    start in ``inits`` (name → ``"base"`` or vertices ``(len(idx), n, 3)``), recording after every step the mean
    relative operator mismatch and the mean ``d_R``. Returns ``curves`` (name → ``step``, ``mismatch``, ``d_R`` lists,
    for :func:`opnet.plotting.plot_refinement_curves`) and ``snapshots`` (name → step → vertices of the first shape):
    ``opnet.experiments.figures.refinement_curves`` with the reproduction's :data:`~opnet.experiments.baselines.REFINE`.
    """
    return _curves(coll, idx, inits, steps, snapshot_steps, device=device, **REFINE)


#: The metrics of the interpolation rows that a row over seeds summarises (:func:`seeded_applications_rows`).
PATH_METRICS = ("smoothness", "distortion", "d_R_truth", "endpoint_d_R")


def seeded_applications_rows(coll, runs_per_seed: list[dict], budget, *, refine=True, device="cpu", out=None,
                             progress=None) -> list[dict]:  # fmt: skip
    """The applications' rows over several trainings of each network: :func:`applications_rows` (with per-question
    and per-path values) for each seed's networks (``runs_per_seed``: one ``{entry key: Run}`` per seed, as
    :func:`application_methods` takes), on the same questions and paths, then each method's rows summarised over the
    seeds (:func:`opnet.experiments.stats.summarize_seeds`: mean, spread, interval; the analogy's d_R, d_V, d_E and the
    interpolation's :data:`PATH_METRICS`). A method that trains nothing (NN, the ground truth) is the same in every
    seed: its first row is kept. Figures (``out``) are drawn from the first seed's networks.
    """
    from .stats import summarize_seeds

    each = []
    for i, runs in enumerate(runs_per_seed):
        methods = application_methods(coll, runs, budget, refine=refine, device=device)
        rows = applications_rows(coll, methods, budget, out=out if i == 0 else None, progress=progress, per_shape=True)
        each.append([dict(r, seed=runs["int+ext"].spec.seed) for r in rows])
    out_rows = []
    for group in zip(*each, strict=True):
        first = group[0]
        if first.get("run") is None:  # NN or the ground truth: deterministic
            out_rows.append({k: v for k, v in first.items() if k != "seed"})
            continue
        metrics = PATH_METRICS if first["table"] == "interpolation" else ("d_R", "d_V", "d_E")
        row = summarize_seeds(list(group), metrics=metrics)
        for key, over_seeds in (("d_R_direct", np.mean), ("d_R_before", np.mean), ("smoothness_max", np.nanmax)):
            if first.get(key) is not None:  # a scalar of each seed's: over the seeds, not the first's alone
                row[key] = nan_stat(over_seeds, [r[key] for r in group])  # NaN: every path of every seed stuck
        if "stuck_paths" in first:
            row["stuck_paths"] = int(sum(r["stuck_paths"] for r in group))
        out_rows.append(row)
    return out_rows
