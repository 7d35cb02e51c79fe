"""Worlds as data: JSON specs (:mod:`.spec`) built into MJCF from a world seed (:mod:`.build`)."""

from __future__ import annotations

from sfa_gym.sim.worlds.build import MJCFParts, World, build_world
from sfa_gym.sim.worlds.layout import WorldLayout
from sfa_gym.sim.worlds.spec import (
    BuildingsSpec,
    InteriorWallsSpec,
    ItemsSpec,
    ObstaclesSpec,
    OutdoorSpec,
    WorldSpec,
    available_worlds,
    load_world_spec,
    world_spec_from_dict,
)

__all__ = [
    "BuildingsSpec",
    "InteriorWallsSpec",
    "ItemsSpec",
    "MJCFParts",
    "ObstaclesSpec",
    "OutdoorSpec",
    "World",
    "WorldLayout",
    "WorldSpec",
    "available_worlds",
    "build_world",
    "load_world_spec",
    "world_spec_from_dict",
]
