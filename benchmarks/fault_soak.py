"""Benchmark: a fault soak of the whole reproduction. SIGKILL at random moments of each of its phases, resumed after
each kill, against an uninterrupted run.

The reproduction is a trimmed ``python -m opnet reproduce --preset quick`` (:func:`child`): the quick humans built
anew into an empty data folder, cut to a few shapes of every sequence, the computed maps from their 2k and 5k meshes
(the "Comp" rows and the discretisation step), Table 1's networks and the refinement rows, with a small training
budget (:data:`BUDGET`); no ablation, applications or figures. It runs in a child process.

The soak (:func:`soak`) starts the child, which says which phase it is in (:func:`phase`), and kills it with
SIGKILL ``--per-phase`` times in each phase (:data:`PHASES`), at a random moment (uniform within
:data:`MAX_DELAY` seconds of the moment the phase is seen; the results write: at once), recording the phase it was
in when it died, then starts it again, until a run ends by itself. An uninterrupted run of the same child into other
folders gives the reference. The rows of the two must be equal, field by field, the timings and the date aside
(:func:`comparable`): every value measured bit for bit the same.

Run::

    .venv/bin/python benchmarks/fault_soak.py --json results/fault_soak.json
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from shape_differences import load_span, run_benchmark

#: The phases of a reproduction, in order, as the soak sees them in its folders (:func:`phase`).
PHASES = ("collection build", "map computation", "training", "evaluation", "results write")
#: The trimmed plan's training budget (the fields of ``opnet.experiments.plan.Budget``).
BUDGET = dict(
    epochs=4, ablation_epochs=1, batch_size=8, hidden=64, refine_steps=5, refine_shapes=2, discretisation_shapes=4
)
#: Shapes kept of every sequence (sub-collection) of the quick humans.
PER_SEQUENCE = 2
#: The latest moment of a kill after its phase is seen, per phase (s): shorter than the phase lasts here (an
#: evaluation of one entry's rows takes well under a second at this size).
MAX_DELAY = {
    "collection build": 1.0,
    "map computation": 20.0,
    "training": 2.0,
    "evaluation": 0.3,
    "results write": 0.0,
}
#: How the report names a phase where its key says less than it holds.
_LABELS = {"evaluation": "evaluation (of the networks' and baselines' rows)"}
#: Fields that are timings, or say when a value was measured: not values (the commit stays: code changed between
#: the two runs would show).
TIMINGS = frozenset({"train_seconds", "seconds_per_shape", "seconds", "wall_seconds", "date"})


def child(out: str, data_root: str) -> None:
    """The trimmed reproduction, in this process: the quick humans built into ``data_root``, cut to
    :data:`PER_SEQUENCE` shapes per sequence (every split kept), reproduced into ``out``. The phase it is in is
    written to ``out/../<out name>.phase`` as it changes (:func:`phase`), by wrappers around the functions that do
    each (the library's code unchanged)."""
    import dataclasses

    import numpy as np

    import opnet
    from opnet import reproduce
    from opnet.data import generators, mapped
    from opnet.experiments.plan import Budget

    marker, stack = _marker(Path(out)), ["start-up"]

    def in_phase(name, fn):
        def wrapper(*args, **kwargs):
            stack.append(name)
            _write(marker, name)
            try:
                return fn(*args, **kwargs)
            finally:
                stack.pop()
                _write(marker, stack[-1])

        return wrapper

    generators._build = in_phase("collection build", generators._build)
    mapped._compute = in_phase("map computation", mapped._compute)
    fit = in_phase("training", opnet.train.fit)
    # a checkpoint after every epoch (it sets no weight: the runs are the same), so that a kill in training resumes
    opnet.train.fit = lambda *args, **kwargs: fit(*args, **{**kwargs, "checkpoint_every": 0})
    reproduce.write_results = in_phase("results write", reproduce.write_results)
    from opnet.experiments import runner

    runner.evaluate = in_phase("evaluation", runner.evaluate)  # run_entries' calls, by their module's names
    runner.evaluate_seeds = in_phase("evaluation", runner.evaluate_seeds)
    humans = opnet.data.profile("humans")

    def load(preset, root=None, progress=None, **draws):
        full = opnet.data.load_collection("humans", preset, root, progress=progress, **draws)
        keep = [np.flatnonzero(full.subcollection == s)[:PER_SEQUENCE] for s in dict.fromkeys(full.subcollection)]
        return full.subset(np.sort(np.concatenate(keep)))

    opnet.data.PROFILES["humans"] = dataclasses.replace(humans, load=load)
    options = dict(ablation=False, figures=False, applications=False, bodies=False, maps=True, refine=True)
    _write(marker, "start-up")
    reproduce.reproduce(
        "quick", out, budget=Budget(**BUDGET), device="cpu", progress=False, data_root=data_root, **options
    )


def _marker(out: Path) -> Path:
    return out.with_name(out.name + ".phase")


def _write(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def phase(out: Path) -> str | None:
    """The phase of the child reproducing into ``out`` (one of :data:`PHASES`, or ``"start-up"`` for all the rest:
    loading, planning, the baselines' optimisation), ``None`` before it says."""
    try:
        return _marker(out).read_text() or None
    except OSError:
        return None


def _start(out: Path, data_root: Path) -> subprocess.Popen:
    """The child in a session of its own (its processes, map workers included, are killed together), its stderr
    in ``<out>.stderr``."""
    code = f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); import fault_soak; "
    code += f"fault_soak.child({str(out)!r}, {str(data_root)!r})"
    _marker(out).unlink(missing_ok=True)
    with open(out.with_name(out.name + ".stderr"), "wb") as err:
        return subprocess.Popen(
            [sys.executable, "-c", code], stdout=subprocess.DEVNULL, stderr=err, start_new_session=True
        )


def _failed(proc: subprocess.Popen, out: Path, what: str) -> RuntimeError:
    tail = out.with_name(out.name + ".stderr").read_text(errors="replace")[-3000:]
    return RuntimeError(f"{what} failed (exit {proc.returncode}):\n{tail}")


def _state(out: Path, data_root: Path) -> dict:
    """What a killed run had left on disk: map parts, runs with a ``latest.pt``, rows written."""
    try:
        rows = len(json.loads((out / "results.json").read_text())["rows"])
    except (OSError, ValueError, KeyError, TypeError):
        rows = 0
    latest = len(list((out / "runs").glob("*/latest.pt"))) if (out / "runs").is_dir() else 0
    return dict(map_parts=len(list(data_root.glob("*.part-*"))), runs_with_latest=latest, rows_written=rows)


def soak(out: Path, data_root: Path, per_phase: int, max_delay: dict, rng: random.Random) -> list[dict]:
    """Kill the child ``per_phase`` times in each phase, at a moment drawn uniformly within ``max_delay[phase]``
    seconds of the phase's start (as seen), resuming after each, until it ends by itself; the kills."""
    kills: list[dict] = []
    wanted = {p: per_phase for p in PHASES}
    while True:
        proc, started = _start(out, data_root), time.perf_counter()
        seen, deadline = None, None
        while proc.poll() is None:
            now = phase(out)
            if now != seen:
                seen = now
                due = wanted.get(now, 0) > 0
                deadline = time.perf_counter() + rng.uniform(0.0, max_delay[now]) if due else None
            if deadline is not None and time.perf_counter() >= deadline:
                os.killpg(proc.pid, signal.SIGKILL)  # the child and its map workers
                if proc.wait() != -signal.SIGKILL:  # it ended by itself just before
                    break
                at = phase(out)  # what it was doing when it died
                wanted[at] = wanted.get(at, 0) - 1
                kills.append(
                    dict(phase=at, after_seconds=round(time.perf_counter() - started, 2), **_state(out, data_root))
                )
                break
            time.sleep(0.001 if now == "evaluation" and wanted["results write"] > 0 else 0.05)  # a write is short
        else:
            if proc.returncode != 0:
                raise _failed(proc, out, "the resumed reproduction")
            return kills
        if proc.returncode == 0:
            return kills
        if proc.returncode != -signal.SIGKILL:
            raise _failed(proc, out, "the resumed reproduction")


def comparable(rows: list[dict]) -> list[dict]:
    """The rows without their timings and dates (:data:`TIMINGS`), in a stable order."""

    def strip(value):
        if isinstance(value, dict):
            return {k: strip(v) for k, v in value.items() if k not in TIMINGS}
        if isinstance(value, list):
            return [strip(v) for v in value]
        return value

    return sorted((strip(r) for r in rows), key=lambda r: json.dumps(r, sort_keys=True))


def differences(rows: list[dict], soaked: list[dict]) -> list[dict]:
    """Where :func:`comparable` rows differ: per (entry, split) row of either, each field whose values differ."""
    key = lambda r: tuple(r.get(k) for k in ("entry", "split", "method", "kind", "resolution", "maps"))  # noqa: E731
    a, b = ({key(r): r for r in comparable(x)} for x in (rows, soaked))
    out = []
    for k in sorted(set(a) | set(b), key=str):
        ra, rb = a.get(k), b.get(k)
        if ra is None or rb is None:
            out.append(dict(row=list(k), only_in="soaked" if ra is None else "uninterrupted"))
            continue
        for field in sorted(set(ra) | set(rb)):
            if ra.get(field) != rb.get(field):
                out.append(dict(row=list(k), field=field, uninterrupted=ra.get(field), soaked=rb.get(field)))
    return out


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--per-phase", type=int, default=2, help="kills in each phase (2: 10 in all)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the kill moments")
    ap.add_argument("--keep", metavar="DIR", help="keep the two reproductions' folders in DIR (default: removed)")
    ap.add_argument("--json", metavar="PATH", help="also write the results as JSON to PATH")
    return ap.parse_args(argv)


def measure(args) -> dict:
    from opnet.experiments.report import read_results

    result = {"date": time.strftime("%Y-%m-%d"), "cpu_count": os.cpu_count(), "budget": BUDGET}
    result["loadavg_1min_at_start"] = round(os.getloadavg()[0], 2)
    if args.keep is not None and Path(args.keep).exists() and any(Path(args.keep).iterdir()):
        raise SystemExit(f"--keep {args.keep} is not empty: give a new folder (a run there would be resumed).")
    with tempfile.TemporaryDirectory() if args.keep is None else contextlib.nullcontext(args.keep) as tmp:
        tmp = Path(tmp)
        tmp.mkdir(parents=True, exist_ok=True)
        t = time.perf_counter()
        reference = _start(tmp / "reference", tmp / "reference-data")
        if reference.wait() != 0:
            raise _failed(reference, tmp / "reference", "the uninterrupted reproduction")
        result["uninterrupted_seconds"] = round(time.perf_counter() - t, 1)
        t = time.perf_counter()
        rng = random.Random(args.seed)
        result["kills"] = soak(tmp / "soak", tmp / "soak-data", args.per_phase, MAX_DELAY, rng)
        result["soak_seconds"] = round(time.perf_counter() - t, 1)
        rows, soaked = read_results(tmp / "reference")[0], read_results(tmp / "soak")[0]
    result["rows"], result["rows_soaked"] = len(rows), len(soaked)
    result["equal"] = comparable(rows) == comparable(soaked)
    result["differences"] = differences(rows, soaked)[:20]
    result["loadavg_1min_at_end"] = round(os.getloadavg()[0], 2)
    return result


def report(r: dict) -> str:
    """The Markdown report of one :func:`measure` result (what the script prints; the docs render the shipped one)."""
    order = {p: i for i, p in enumerate(PHASES)}
    kills = sorted(r["kills"], key=lambda k: order.get(k["phase"], len(PHASES)))
    lines = [
        f"A trimmed `reproduce --preset quick` (the quick humans built anew, {PER_SEQUENCE} shapes per sequence, "
        f"computed maps from 2k and 5k meshes, Table 1's networks and the refinement rows; budget "
        f"{', '.join(f'{k}={v}' for k, v in r['budget'].items())}), killed with SIGKILL {len(r['kills'])} times "
        f"and resumed after each ({load_span(r)}; measured {r['date']}, {r['cpu_count']} cores). Each kill, with "
        "what the killed run had left on disk:",
        "",
        "| phase | seconds after the (re)start | map parts | runs with a `latest.pt` | rows written |",
        "|---|---:|---:|---:|---:|",
        *(
            f"| {_LABELS.get(k['phase'], k['phase'])} | {k['after_seconds']:.1f} | {k.get('map_parts', '–')} | "
            f"{k.get('runs_with_latest', '–')} | {k.get('rows_written', '–')} |"
            for k in kills
        ),
        "",
        f"Uninterrupted: {r['uninterrupted_seconds']:.0f} s; with the kills and resumes: {r['soak_seconds']:.0f} s. "
        f"The {r['rows']} rows of the two are "
        + ("**equal**, every field but the timings." if r["equal"] else "**NOT equal**."),
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    run_benchmark("Fault soak of the reproduction", parse_args, measure, report)
