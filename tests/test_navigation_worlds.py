"""Obstacle placement of the navigation worlds: every world seed builds, the obstacles keep their
gaps, worlds that built before are unchanged, and an impossible spec says what to change."""

from __future__ import annotations

import dataclasses
import hashlib
import math

import gymnasium as gym
import pytest

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.sim.worlds import build_world
from sfa_gym.sim.worlds.spec import ObstaclesSpec, load_world_spec

# World seeds of paper_sim_obstacles whose first obstacles left a later one only slivers of
# room (100, 351) or none at all (461, 950): random draws alone failed to place all six.
CROWDED_SEEDS = (100, 351, 461, 950)

# The MJCF of paper_sim_obstacles at world seed 0, as built before the fallbacks existed.
OBSTACLES_SEED0_SHA256 = "4acf7d9f2762bd9d080b54c3e5489d26d97d31da7910f2fee17170c47c0df503"


@pytest.fixture(scope="module")
def spec():
    return load_world_spec("paper_sim_obstacles")


def _check_gaps(spec, layout) -> None:
    half = spec.arena.size[0] / 2
    gap = spec.obstacles.min_gap
    assert len(layout.obstacles) == spec.obstacles.count
    for i, (x, y, r) in enumerate(layout.obstacles):
        assert max(abs(x), abs(y)) + r <= half - gap + 1e-9
        for x2, y2, r2 in layout.obstacles[:i]:
            assert math.hypot(x - x2, y - y2) >= r + r2 + gap - 1e-9


@pytest.mark.parametrize("seed", CROWDED_SEEDS)
def test_crowded_world_seeds_build_with_every_gap_kept(spec, seed):
    world = build_world(spec, seed)
    _check_gaps(spec, world.layout)
    assert world.mjcf.count('name="obstacle') == spec.obstacles.count
    # a function of the seed
    assert build_world(spec, seed).mjcf == world.mjcf


def test_worlds_that_built_before_are_unchanged(spec):
    mjcf = build_world(spec, 0).mjcf
    assert hashlib.sha256(mjcf.encode()).hexdigest() == OBSTACLES_SEED0_SHA256


def test_obstacles_world_seed_100_makes_a_navigation_env():
    env = gym.make("sfa_gym/OmniRoverNavObstacles-v0", world_seed=100)
    _, info = env.reset(seed=0)
    assert len(env.unwrapped.layout.obstacles) == 6
    assert math.isfinite(info["shortest_path"]) and info["shortest_path"] >= 1.0
    env.close()


def test_obstacles_without_room_name_the_seed_and_what_to_change(spec):
    crowded = dataclasses.replace(spec, obstacles=ObstaclesSpec(count=40, min_gap=1.0))
    with pytest.raises(ValueError, match=r"world seed 7: cannot place 40 obstacles.*reduce"):
        build_world(crowded, 7)
