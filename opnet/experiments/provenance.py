"""Where a row comes from: the trainings it measured (run ids and the SHA-256 of each ``best.pt``), its seeds, the
code (commit), date, machine and preset, and a digest of everything its numbers depend on.

Every row that :func:`opnet.experiments.runner.run_entries` and ``reproduce``'s steps write carries a
``provenance`` dict (:func:`record`). ``reproduce`` uses it twice: a row whose ``inputs`` digest equals what it
would measure now is kept instead of evaluated again (a stopped reproduction resumes without repeating its
evaluations), and a row kept from an earlier call that records another checkpoint of a run than the one the folder
holds, or than this call measured, is dropped (:func:`superseded`), so that one results file never mixes trainings
under one run. A row whose runs are not in the folder at all (a results file carried to another machine, the
shipped one among them) is kept: its provenance names the trainings it measured, and a call that trains them again
replaces it, or drops it if the new checkpoint differs.
"""

from __future__ import annotations

import functools
import hashlib
import json
import subprocess
from pathlib import Path

__all__ = [
    "EVALUATION_VERSION",
    "code_version",
    "machine",
    "stamp",
    "record",
    "inputs_digest",
    "current",
    "superseded",
    "measured_checkpoints",
    "run_checkpoints",
    "run_finished",
]


#: Bump when a change to the evaluation code changes what a row of the same checkpoints and data measures: every
#: :func:`inputs_digest` holds it, so rows of an older version are measured again instead of kept.
EVALUATION_VERSION = 1


@functools.cache
def code_version() -> str | None:
    """The git commit of the opnet source tree it runs from, with ``-dirty`` when tracked files differ from it;
    ``None`` for an installed package (no git checkout) or without git.
    """
    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists():
        return None
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head + ("-dirty" if dirty else "")


def machine(device) -> str:
    """What a measurement ran on, in words: the GPU's name (CUDA) or the CPU's architecture, cores and torch threads,
    and torch's version.
    """
    import os
    import platform

    import torch

    device = torch.device(device)
    if device.type == "cuda":
        return f"{torch.cuda.get_device_name(device)} (CUDA), torch {torch.__version__}"
    return (
        f"CPU ({platform.machine()}, {os.cpu_count()} cores, {torch.get_num_threads()} torch threads), "
        f"torch {torch.__version__}"
    )


def stamp(device, collection=None) -> dict:
    """The ``commit`` (:func:`code_version`), ``date`` (today), ``machine`` (:func:`machine` of ``device``) and
    ``preset`` (the collection's) that a call's rows record in their :func:`record`.
    """
    import time

    from ..devices import resolve_device

    preset = None if collection is None else collection.meta.get("preset")
    return dict(
        commit=code_version(), date=time.strftime("%Y-%m-%d"), machine=machine(resolve_device(device)), preset=preset
    )


def inputs_digest(**parts) -> str:
    """16 hex digits of SHA-256 over ``parts`` (JSON with sorted keys; anything else by ``str``): what a row's numbers
    depend on (the entry, the checkpoints, the data, the evaluation settings; and :data:`EVALUATION_VERSION`), in its
    ``provenance["inputs"]``.
    """
    parts = dict(parts, evaluation_version=EVALUATION_VERSION)
    return hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()[:16]


def record(runs, context: dict, inputs: str) -> dict:
    """A row's ``provenance``.

    Parameters
    ----------
    runs : sequence of opnet.experiments.runner.Run
        The trainings the row measured (none for a baseline).
    context : dict
        ``commit``, ``date``, ``machine`` and ``preset`` of the call that measures it.
    inputs : str
        :func:`inputs_digest` of what its numbers depend on.

    Returns
    -------
    dict
        ``runs`` (run ids: the folders' names), ``checkpoints`` (the SHA-256 of each run's ``best.pt``, in order),
        ``seeds``, ``commit``, ``date``, ``machine``, ``preset``, ``inputs``.
    """
    return dict(
        runs=[r.run_id for r in runs],
        checkpoints=[r.checkpoint for r in runs],
        seeds=[r.spec.seed for r in runs],
        **{k: context.get(k) for k in ("commit", "date", "machine", "preset")},
        inputs=inputs,
    )


def run_checkpoints(runs_root, *, finished: bool = False) -> dict:
    """``{run id: SHA-256 of its best.pt}`` for every run folder under ``runs_root`` that has one; ``finished``: only
    the runs whose ``history.json`` holds the epochs their ``config.json`` asks for (an interrupted training's
    ``best.pt`` is not its result yet). A file's digest is computed once per size and modification time.
    """
    root = Path(runs_root)
    if not root.is_dir():
        return {}
    out = {}
    for path in sorted(root.glob("*/best.pt")):
        if finished and not run_finished(path.parent):
            continue
        stat = path.stat()
        out[path.parent.name] = _sha256(str(path), stat.st_size, stat.st_mtime_ns)
    return out


@functools.lru_cache(maxsize=4096)
def _sha256(path: str, size: int, mtime_ns: int) -> str:
    from ..train import checkpoint_sha256

    return checkpoint_sha256(Path(path))


def run_finished(run_dir, epochs: int | None = None) -> bool:
    """Whether the run in ``run_dir`` has trained ``epochs`` epochs (default: those of its ``config.json``), by its
    ``history.json``, read without loading the run; ``False`` where either file is missing or unreadable.
    """
    run_dir = Path(run_dir)
    try:
        if epochs is None:
            epochs = json.loads((run_dir / "config.json").read_text())["train"]["epochs"]
        return len(json.loads((run_dir / "history.json").read_text())) >= epochs
    except (OSError, ValueError, KeyError, TypeError):
        return False


def current(row: dict, checkpoints: dict) -> bool:
    """Whether ``row`` measured the trainings that are its runs' current ones: it has a ``provenance`` and each run it
    records has, in ``checkpoints`` (:func:`run_checkpoints`), the SHA-256 it recorded. A row without one (written
    before rows recorded their trainings) cannot say, so it is not current.
    """
    prov = row.get("provenance")
    if not isinstance(prov, dict):
        return False
    return all(checkpoints.get(run) == sha for run, sha in zip(prov["runs"], prov["checkpoints"], strict=True))


def superseded(row: dict, checkpoints: dict, *, by_name: bool = False) -> bool:
    """Whether ``row`` measured a training that is no longer its run's: one of the runs it records is in
    ``checkpoints`` (``{run id: SHA-256}``: :func:`run_checkpoints` of a folder, or the runs a call measured) with
    another SHA-256 than the row recorded; with ``by_name``, also when ``checkpoints`` has a run of the same name
    under another id (the name without the digest of its data and code: the same network trained on other data or
    by other code, as a call that measured it says). A run absent from ``checkpoints`` does not supersede it (its
    folder is not on this machine; the row stands as measured). A row without a ``provenance`` (written before rows
    recorded their trainings) cannot say, so it is superseded.
    """
    prov = row.get("provenance")
    if not isinstance(prov, dict):
        return True
    names = {_run_name(run) for run in checkpoints} if by_name else set()
    for run, sha in zip(prov["runs"], prov["checkpoints"], strict=True):
        if checkpoints.get(run, sha) != sha or (run not in checkpoints and _run_name(run) in names):
            return True
    return False


def _run_name(run_id: str) -> str:
    """A run id without its digest (:meth:`opnet.experiments.spec.RunSpec.run_id`: ``<run name>-<digest>``)."""
    return run_id.rpartition("-")[0]


def measured_checkpoints(rows) -> dict:
    """``{run id: SHA-256}`` of every training the ``rows`` record in their ``provenance`` (a call's own rows: the
    checkpoints it measured, which supersede an earlier row's other checkpoint of the same run, :func:`superseded`).
    """
    return {
        run: sha
        for r in rows
        if isinstance(r.get("provenance"), dict)
        for run, sha in zip(r["provenance"]["runs"], r["provenance"]["checkpoints"], strict=True)
    }
