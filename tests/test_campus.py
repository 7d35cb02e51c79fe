"""The campus world: building blocks inside the square that the rover drives round, buildings
that repeat a few designs, the layout's clearance of blocks, and the spec's checks."""

from __future__ import annotations

import dataclasses
import math
import re

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.navigation.occupancy import OccupancyGrid
from sfa_gym.sim.worlds import WorldLayout, build_world, load_world_spec

CAMPUS = load_world_spec("campus")


def _sizes(mjcf: str, prefix: str) -> list[tuple[float, ...]]:
    """``(short, long, height)`` half sizes of the box geoms whose names start with ``prefix``
    (the footprint's sides sorted: a row's buildings turn with their side)."""
    pattern = rf'<geom name="{prefix}\d+" type="box" pos="[^"]*" size="([^"]*)"'
    sizes = [tuple(map(float, s.split())) for s in re.findall(pattern, mjcf)]
    return [(*sorted((x, y)), z) for x, y, z in sizes]


@pytest.mark.parametrize("seed", [0, 5])
def test_every_building_repeats_one_of_the_designs(seed):
    world = build_world(CAMPUS, seed)
    buildings = _sizes(world.mjcf, "building")
    assert len(buildings) >= 4
    # two designs: at most two footprints and heights among all the rows' buildings
    assert len(set(buildings)) <= CAMPUS.outdoor.buildings.designs
    blocks = _sizes(world.mjcf, "block")
    assert len(blocks) == len(CAMPUS.outdoor.blocks) == len(world.layout.blocks)
    # a block is as tall as a design's storeys
    heights = {b[2] for b in buildings} | {b[2] for b in blocks}
    storey = CAMPUS.outdoor.buildings.storey_height
    assert all(math.isclose((2 * h / storey) % 1, 0, abs_tol=1e-3) for h in heights)
    # the same seed builds the same world
    assert build_world(CAMPUS, seed).mjcf == world.mjcf


def test_the_worlds_without_designs_draw_every_building_anew():
    outdoor = load_world_spec("paper_outdoor")
    assert outdoor.outdoor.buildings.designs == 0
    buildings = _sizes(build_world(outdoor, 0).mjcf, "building")
    assert len(set(buildings)) == len(buildings)  # every footprint its own


def test_block_clearance_is_the_distance_to_the_box():
    layout = WorldLayout((-5, 5, -5, 5), (), (), blocks=((0.0, 2.0, 0.0, 1.0),))
    points = [(3.0, 0.5), (3.0, 2.0), (1.0, 0.5), (1.0, 0.9), (-1.0, -1.0)]
    expected = [1.0, math.hypot(1.0, 1.0), -0.5, -0.1, math.hypot(1.0, 1.0)]
    np.testing.assert_allclose(layout.clearance(points), expected, atol=1e-12)
    with pytest.raises(ValueError, match=r"blocks\[0\] must have xmin < xmax"):
        WorldLayout((-5, 5, -5, 5), (), (), blocks=((2.0, 0.0, 0.0, 1.0),))


def test_the_rover_drives_round_the_blocks_not_through_them():
    env = gym.make(
        "sfa_gym/OmniRoverCampus-v0", sensor=False, dynamics=False, disable_env_checker=True
    )
    try:
        u = env.unwrapped
        x0, x1, y0, y1 = u.layout.blocks[0]
        # a pose inside the wing is refused, one in the path beside it is taken
        with pytest.raises(ValueError, match="from an obstacle or interior wall"):
            env.reset(seed=0, options={"pose": ((x0 + x1) / 2, (y0 + y1) / 2, 0.0)})
        grid = OccupancyGrid.from_layout(u.layout, u.rover.footprint_radius, 0.25)
        assert not grid.is_free(np.array([[(x0 + x1) / 2, (y0 + y1) / 2]]))[0]
        # full speed north, straight at the wing from 1.5 m south of it: the rover stops at it
        env.reset(seed=0, options={"pose": (2.0, y0 - 1.5, math.pi / 2)})
        for _ in range(60):
            _, _, _, _, info = env.step(np.array([u.v_max, 0.0], np.float32))
        y = info["y"]
        assert y < y0, y
        assert y > y0 - 1.0  # it got there
    finally:
        env.close()


def test_bad_blocks_and_designs_are_named():
    outdoor = CAMPUS.outdoor
    with pytest.raises(ValueError, match="blocks look like the buildings' designs"):
        dataclasses.replace(outdoor, buildings=dataclasses.replace(outdoor.buildings, designs=0))
    with pytest.raises(ValueError, match="buildings designs must be an int >= 0"):
        dataclasses.replace(outdoor.buildings, designs=-1)
    with pytest.raises(ValueError, match=r"blocks\[0\] must be \(xmin, xmax, ymin, ymax\)"):
        dataclasses.replace(outdoor, blocks=((1.0, 0.0, 0.0, 1.0),))
    far = dataclasses.replace(outdoor, blocks=((0.0, 1.0, 14.0, 16.0),))
    with pytest.raises(ValueError, match="reaches outside the arena"):
        dataclasses.replace(CAMPUS, outdoor=far)


def test_the_grid_protocol_keeps_to_the_cells_where_the_rover_fits(tmp_path):
    from sfa_gym.protocols import grid
    from sfa_gym.recording.cache import RunCache

    config = grid.Config(
        env_id="sfa_gym/OmniRoverCampus-v0",
        panorama=(20, 200),
        grid=9,
        free_cells=True,
        n_train=12,
        n_test=6,
    )
    config.validate()
    data = grid.load(config, 0, RunCache(tmp_path, progress=False))
    env = gym.make("sfa_gym/OmniRoverCampus-v0", disable_env_checker=True)
    try:
        assert np.all(env.unwrapped.rover_fits(data.positions))
    finally:
        env.close()
    assert len(data.positions) < config.grid**2  # the wings' cells are left out
    assert len(set(data.train) | set(data.test)) == config.n_train + config.n_test
    crowded = dataclasses.replace(config, n_train=len(data.positions), n_test=6)
    with pytest.raises(ValueError, match="only .* where the rover fits"):
        grid.select_positions(crowded, len(data.positions))


def test_the_way_between_the_plazas_turns_round_both_wings():
    env = gym.make("sfa_gym/OmniRoverNavCampus-v0", sensor=False, dynamics=False)
    try:
        obs, info = env.reset(seed=0, options={"start": (0, -10, 0), "goal": (0, 10, 0)})
        assert obs["panorama"].shape == obs["goal"].shape == (40, 350, 3)  # mirror, unwarped
        # 20 m apart in a straight line; the paths lie at the wings' alternating ends
        assert info["shortest_path"] > 1.8 * 20.0
        # the way from the south plaza to the middle court passes one wing: shorter
        _, info = env.reset(seed=0, options={"start": (0, -10, 0), "goal": (0, 0, 0)})
        assert 10.0 * 1.2 < info["shortest_path"] < 40.0
    finally:
        env.close()


def test_the_navigation_protocol_renders_with_the_campus_camera():
    from sfa_gym.protocols.navigation import _request
    from sfa_gym.recording.poses import FieldNodes

    for nav_id, scene_id in (
        ("sfa_gym/OmniRoverNavCampus-v0", "sfa_gym/OmniRoverCampus-v0"),
        ("sfa_gym/OmniRoverNav-v0", "sfa_gym/OmniRover-v0"),
    ):
        env = gym.make(nav_id, disable_env_checker=True)
        try:
            request = _request(env.unwrapped, FieldNodes(0.5), 0)
            assert request.env_id == scene_id
            assert request.panorama == env.observation_space["panorama"].shape[:2]
        finally:
            env.close()
