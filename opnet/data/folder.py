"""A collection from a folder of your own meshes in correspondence (:func:`load_folder`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._deprecation import renamed_keyword
from ..inner_products import split_channels
from ..mesh import MeshError, load_mesh
from ..shape_difference import KINDS
from .build import assemble
from .storage import SPLITS, Collection, CollectionError

__all__ = ["load_folder"]


@renamed_keyword("kinds", "channels")
def load_folder(
    folder, *, base: str | None = None, k: int = 60, channels=None, progress: bool | None = None
) -> Collection:
    """A collection from a folder of your own meshes in correspondence (same faces, any of .ply .obj .off).

    Shapes are read in file-name order (hidden files are skipped); ``base`` names the file used as base
    shape, with or without its extension (default: the first). An optional ``splits.csv`` with lines
    ``filename,split,subcollection`` or ``filename,split,subcollection,subject`` (a header line ``filename,...``
    is allowed) assigns splits; every sub-collection must lie in one split. A shape's subject is its
    sub-collection's name when not given. Unlisted shapes are ``"train"``, each in a sub-collection (and subject)
    named after its file. ``channels``: the channels to compute (names or inner products, default
    :data:`opnet.KINDS`), in that order. Save the result with :func:`~opnet.data.save_collection`.
    """
    folder = Path(folder).resolve()
    if not folder.is_dir():
        raise CollectionError(f"{folder} is not a folder; pass the folder that holds your meshes.")
    files = sorted(
        p
        for p in folder.iterdir()
        if p.suffix.lower() in (".ply", ".obj", ".off") and not p.name.startswith(".") and p.is_file()
    )
    if not files:
        raise CollectionError(f"no .ply/.obj/.off meshes in {folder}.")
    meshes = []
    for p in files:
        try:
            meshes.append(load_mesh(p))
        except MeshError as exc:
            raise CollectionError(f"{p.name} is not a usable mesh ({exc}); repair that file.") from None
    for p, m in zip(files, meshes):
        if not np.array_equal(m.faces, meshes[0].faces):
            raise CollectionError(
                f"{p.name} has other faces than {files[0].name}: the meshes must be in 1-1 correspondence "
                "with one shared triangulation."
            )
    names = [p.name for p in files]
    split = np.full(len(files), "train", dtype=object)
    subcollection = np.array([p.stem for p in files], dtype=object)
    subject = subcollection.copy()
    table = folder / "splits.csv"
    if table.is_file():
        seen = set()
        try:
            lines = table.read_text(encoding="utf-8").splitlines()
        except UnicodeDecodeError:
            raise CollectionError(
                f"{table.name} is not UTF-8 text; write it as lines 'filename,split,subcollection[,subject]' "
                f"(in {folder})."
            ) from None
        for line_no, line in enumerate(lines, 1):
            fields = [f.strip() for f in line.split(",")]
            if not line.strip() or (line_no == 1 and fields[0] == "filename"):
                continue
            known = fields[0] in names and fields[0] not in seen and fields[1] in SPLITS
            if len(fields) not in (3, 4) or not known or not all(fields):
                raise CollectionError(
                    f"{table}:{line_no}: expected 'filename,split,subcollection[,subject]' with a known file "
                    f"listed once, a split in {SPLITS} and no empty field, got {line!r}."
                )
            seen.add(fields[0])
            i = names.index(fields[0])
            split[i], subcollection[i] = fields[1], fields[2]
            subject[i] = fields[-1]  # the sub-collection when there is no fourth field
        for sc in set(subcollection):
            if len(set(split[subcollection == sc])) > 1:
                raise CollectionError(
                    f"{table}: sub-collection {sc!r} spans the splits {sorted(set(split[subcollection == sc]))}; "
                    "a sub-collection is held out whole, so give all its shapes one split."
                )
        both = set(subject[split == "test_subjects"]) & set(subject[split != "test_subjects"])
        if both:
            raise CollectionError(
                f"{table}: the subjects {sorted(both)} have shapes in "
                "'test_subjects' and in other splits; the test_subjects split holds subjects never seen in training, "
                "so give all their shapes that split."
            )
    stems = [p.stem for p in files]
    if base is None:
        base_index = 0
    elif base in names or base in stems:
        base_index = names.index(base) if base in names else stems.index(base)
    else:
        raise CollectionError(f"base {base!r} is not one of the meshes in {folder}.")
    vertices = np.stack([m.vertices for m in meshes])
    meta = dict(
        name=folder.name,
        preset="folder",
        resolution=f"{vertices.shape[1]}",
        seed=0,
        generator_version="folder",
        base=names[base_index],
    )
    return assemble(
        vertices,
        meshes[0].faces,
        vertices[base_index],
        split.astype(str),
        subcollection.astype(str),
        subject.astype(str),
        {"filename": np.array(names)},
        meta,
        k=k,
        progress=progress,
        channels=KINDS if channels is None else split_channels(channels),
    )
