"""Collections as profiles: one record per collection that the reproduction runs on, saying what applies to it.

A :class:`Profile` holds a collection's name, how to load it at a preset, its triangulations, whether computed maps
onto its base and more drawn bodies apply, its analogy and interpolation kinds, the camera that shows it from the
side, the sentence that describes it in ``results.md``, and whether the paper publishes numbers on it. Code that
would branch on a collection's name reads its profile instead, so a new collection is a module that builds it and
one :func:`register_profile` call::

    opnet.data.register_profile(opnet.data.Profile("capsules", load=lambda preset, root, progress: my_collection()))
    opnet.reproduce.reproduce(opnet.reproduce.ReproduceConfig(collection="capsules", ...))
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from .generators import GENERATORS, load_collection

__all__ = ["Profile", "PROFILES", "register_profile", "unregister_profile", "profile", "profile_of", "reproducible"]

_HUMAN_ANALOGIES = {
    "pose": "pose transfer (a,p):(a,q)::(b,p):(b,q)",
    "body": "body transfer (a,p):(b,p)::(a,q):(b,q)",
    "gender": "gender transfer (a♂,p):(a♀,p)::(b♂,q):(b♀,q)",
}
_HUMAN_PATHS = {"pose": "one subject, pose to pose", "body": "one pose, subject to subject"}


@dataclass(frozen=True)
class Profile:
    """What applies to one collection (see the module's docstring).

    Parameters
    ----------
    name : the collection's name (its ``meta["name"]``; ``reproduce --collection NAME``).
    load : ``load(preset, root, progress, **draws) → Collection``; ``draws`` are ``load_collection``'s ``bodies`` and
        ``poses`` (only asked of a profile with ``more_bodies``).
    resolutions : its triangulations, the base's first.
    computed_maps : its other triangulations can be mapped onto the base (the "Comp" rows, other discretisations).
    more_bodies : its training shapes can be drawn with more bodies or poses (``load_collection(bodies=, poses=)``).
    applications : its generator gives ground truth for the analogy and interpolation benchmarks.
    analogy_kinds, interpolation_kinds : the benchmarks' kinds (:data:`opnet.apps.ANALOGY_KINDS`) → their names in
        the report; the analogy benchmark runs the kinds named here (none named: ``"pose"`` and ``"body"``).
    view : the pyvista camera that shows its shapes from the side (``"xz"``: z up; ``"zy"``: y up).
    context : what ``results.md`` says of its data.
    paper_numbers : whether the paper publishes numbers on such data (its Table 1 and ablation are set beside ours,
        with the targets).
    reproducible : offered by ``python -m opnet reproduce --collection`` (and shipped when measured).
    folder_prefix : the prefix of its reproduction's folders (``reproduce-<prefix><preset>``, shipped as
        ``<prefix><preset>``; default ``"<name>-"``).
    """

    name: str
    load: Callable = field(repr=False, default=None)
    resolutions: tuple = ("native",)
    computed_maps: bool = False
    more_bodies: bool = False
    applications: bool = False
    analogy_kinds: dict = field(default_factory=dict, hash=False)
    interpolation_kinds: dict = field(default_factory=dict, hash=False)
    view: str = "xz"
    context: str = ""
    paper_numbers: bool = False
    reproducible: bool = True
    folder_prefix: str | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValueError(f"a profile's name must be an identifier such as 'capsules', got {self.name!r}.")
        if self.load is None:
            if self.name not in GENERATORS:
                raise ValueError(
                    f"profile {self.name!r} needs load=: a function (preset, root, progress, **draws) -> Collection "
                    f"(only the generated collections {sorted(GENERATORS)} load without one)."
                )
            object.__setattr__(self, "load", _generated(self.name))
        if self.folder_prefix is None:
            object.__setattr__(self, "folder_prefix", f"{self.name}-")

    def folder(self, preset: str) -> str:
        """The name of its reproduction's folder at ``preset``: ``<folder_prefix><preset>``."""
        return f"{self.folder_prefix}{preset}"


def _generated(name: str) -> Callable:
    def load(preset, root=None, progress=None, **draws):
        return load_collection(name, preset, root, progress=progress, **draws)

    return load


_ANIMALS_CONTEXT = (
    "The shapes: the animals of `opnet.data.animals` (Quaternius' quadrupeds on the horse's template, species and "
    "blends between them; `test_subjects` holds held-out blends and the wolf, a species never seen in training; "
    '"unseen species" is the wolf alone). The paper trains on SMAL animals but publishes no numbers for them.'
)

#: The registered profiles, by name (:func:`register_profile` adds one).
PROFILES: dict[str, Profile] = {}


def register_profile(p: Profile, *, replace: bool = False) -> Profile:
    """Register ``p`` under its name (``replace=True`` to overwrite a registered one); returns it."""
    if not isinstance(p, Profile):
        raise TypeError(f"register_profile takes an opnet.data.Profile, got {type(p).__name__}.")
    if p.name in PROFILES and not replace:
        raise ValueError(f"a profile {p.name!r} is registered already; pass replace=True to overwrite it.")
    PROFILES[p.name] = p
    return p


def unregister_profile(name: str) -> None:
    """Remove the profile ``name`` (a test's own, say); the built-in ones can be removed too."""
    PROFILES.pop(name, None)


def profile(name: str) -> Profile:
    """The registered profile ``name``; a ``ValueError`` naming the registered ones otherwise."""
    if name not in PROFILES:
        raise ValueError(
            f"no collection profile {name!r}; registered: {sorted(PROFILES)} (opnet.data.register_profile adds one)."
        )
    return PROFILES[name]


def profile_of(name: str | None) -> Profile:
    """The profile of a collection named ``name`` (a row's or a results file's ``data``; ``None``: the humans, as
    files written before it was recorded), or a plain profile when none is registered: no paper numbers, no maps.
    """
    name = "humans" if name is None else name
    return PROFILES[name] if name in PROFILES else Profile(name, load=_unregistered, reproducible=False)


def _unregistered(*args, **kwargs):
    raise ValueError("this collection has no registered profile: register one (opnet.data.register_profile).")


def reproducible() -> tuple[str, ...]:
    """The names of the collections ``reproduce`` runs on (registered, ``reproducible``), in registration order."""
    return tuple(name for name, p in PROFILES.items() if p.reproducible)


for _p in (
    Profile(
        "humans",
        resolutions=GENERATORS["humans"][1],
        computed_maps=True,
        more_bodies=True,
        applications=True,
        analogy_kinds=_HUMAN_ANALOGIES,
        interpolation_kinds=_HUMAN_PATHS,
        context="The paper's numbers are on DFAUST, ours on `anny` humans: the scale (metres) is alike, the data are "
        "not the same.",
        paper_numbers=True,
        folder_prefix="",
    ),
    Profile(
        "animals",
        applications=True,
        analogy_kinds={
            "pose": "pose transfer (a,p):(a,q)::(b,p):(b,q)",
            "body": "animal-type transfer (a,p):(b,p)::(a,q):(b,q)",
        },
        interpolation_kinds={"pose": "one animal, frame to frame of a clip", "body": "one pose, species to species"},
        view="zy",
        context=_ANIMALS_CONTEXT,
    ),
    *(
        Profile(
            name,
            more_bodies=True,
            applications=True,
            analogy_kinds=_HUMAN_ANALOGIES,
            interpolation_kinds=_HUMAN_PATHS,
            context=f"The shapes: `anny` {name}.",
            reproducible=False,
        )
        for name in ("heads", "hands")
    ),
):
    register_profile(_p)
del _p
