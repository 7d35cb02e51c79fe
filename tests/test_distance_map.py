"""The goal's distance map (one Dijkstra per goal, looked up per step) against the exact geodesic
query, and the navigation env's use of it."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import sfa_gym  # noqa: F401  (registers the ids)
from sfa_gym.navigation.distance_map import GeodesicMap
from sfa_gym.navigation.occupancy import OccupancyGrid
from sfa_gym.sim.rover import RoverSpec
from sfa_gym.sim.worlds import WorldLayout, build_world, load_world_spec

ROVER = RoverSpec().footprint_radius


def _grid(world: str, seed: int = 0) -> OccupancyGrid:
    return OccupancyGrid.from_layout(build_world(load_world_spec(world), seed).layout, ROVER)


@pytest.mark.parametrize("world, seed", [("paper_sim_obstacles", 0), ("paper_sim_maze", 0),
                                         ("paper_sim_obstacles", 100)])  # fmt: skip
def test_map_agrees_with_the_exact_query(world, seed):
    grid = _grid(world, seed)
    rng = np.random.default_rng(7)
    for goal in grid.sample_free(rng, 3):
        exact, fast = grid.geodesic(goal), GeodesicMap(grid, goal)
        # free points, and points anywhere (also outside free space: measured from the
        # nearest free cell centre by both)
        points = np.vstack([grid.sample_free(rng, 150), rng.uniform(-3.3, 3.3, size=(50, 2))])
        want, got = exact.distance(points), fast.distance(points)
        # 32-neighbour moves are at most 1.3 % longer than a straight line; interpolation
        # between cell centres (5 cm apart) adds or takes a couple of centimetres
        assert np.all(got <= want * 1.015 + 0.02), np.max(got - want * 1.015)
        assert np.all(got >= want - 0.025), np.max(want - got)
        # near the goal, inside a disc that free space holds (the grid's cells may block up
        # to half a cell diagonal more than the exact clearance), it is exact
        radius = max(grid.clearance(goal[None])[0] - grid.resolution / math.sqrt(2), 0.0)
        angle = rng.uniform(0, 2 * math.pi, 20)
        near = goal + np.column_stack([np.cos(angle), np.sin(angle)]) * radius * rng.random((20, 1))
        np.testing.assert_allclose(fast.distance(near), exact.distance(near), atol=1e-9)


def test_map_walks_around_a_wall_and_knows_unreachable_goals():
    layout = WorldLayout((-3.0, 3.0, -3.0, 3.0), (), (), walls=((-3.5, 0.0, 1.0, 0.0, 0.05),))
    grid = OccupancyGrid.from_layout(layout, 0.3)
    fast = GeodesicMap(grid, (-2.0, 1.0))
    # straight across is 2 m; around the wall's inflated end (x = 1.35) much longer
    d = fast.distance_at(-2.0, -1.0)
    assert d == pytest.approx(grid.shortest_path_length((-2.0, -1.0), (-2.0, 1.0)), rel=0.015)
    assert d > 6.5
    closed = WorldLayout((-3.0, 3.0, -3.0, 3.0), (), (), walls=((-3.5, 0.0, 3.5, 0.0, 0.05),))
    split = GeodesicMap(OccupancyGrid.from_layout(closed, 0.3), (0.0, 1.0))
    assert math.isinf(split.distance_at(0.0, -1.0))
    assert np.isnan(split.values[~split.grid.free]).all()


def test_bad_goals_and_points():
    grid = _grid("paper_sim_maze")
    with pytest.raises(ValueError, match="not in free space"):
        GeodesicMap(grid, (0.0, 0.0))  # the middle of the plus-shaped wall
    with pytest.raises(ValueError, match="shape"):
        GeodesicMap(grid, (2.0, 2.0)).distance(np.zeros(3))


def test_env_reports_the_maps_distance_and_the_exact_shortest_path():
    env = gym.make("sfa_gym/OmniRoverNavObstacles-v0")
    u = env.unwrapped
    _, info = env.reset(seed=3)
    exact = u.occupancy.geodesic(info["goal"][:2])
    start = np.array([info["start"][:2]])
    assert info["shortest_path"] == pytest.approx(exact.distance(start)[0], abs=1e-12)
    assert info["geodesic_distance"] == pytest.approx(info["shortest_path"], rel=0.015, abs=0.02)
    rewards = []
    for _ in range(20):
        _, reward, *_, info = env.step(np.array([0.3, 0.2, -1.0], dtype=np.float32))
        rewards.append(reward)
        here = np.array([[info["x"], info["y"]]])
        assert info["geodesic_distance"] == pytest.approx(
            exact.distance(here)[0], rel=0.015, abs=0.025
        )
    env.close()
