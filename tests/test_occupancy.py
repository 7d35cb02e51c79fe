"""Occupancy grid and geodesic distance: free space, line of sight, known-answer shortest paths,
agreement with brute force, components, sampling, speed."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.sparse import csgraph, csr_matrix

from sfa_gym.navigation.occupancy import GeodesicField, OccupancyGrid
from sfa_gym.sim.rover import RoverSpec
from sfa_gym.sim.worlds import WorldLayout, build_world, load_world_spec

BOUNDS = (-3.0, 3.0, -3.0, 3.0)
ROVER = RoverSpec().footprint_radius


def _layout(obstacles=(), walls=()) -> WorldLayout:
    return WorldLayout(BOUNDS, tuple(obstacles), (), walls=tuple(walls))


@pytest.fixture(scope="module")
def maze():
    layout = build_world(load_world_spec("paper_sim_maze"), 0).layout
    return OccupancyGrid.from_layout(layout, ROVER)


@pytest.fixture(scope="module")
def obstacles():
    layout = build_world(load_world_spec("paper_sim_obstacles"), 0).layout
    return OccupancyGrid.from_layout(layout, ROVER)


def _wrap_length(a, b, centre, radius, side):
    """Exact length of the shortest path from a to b around a disc (tangent, arc, tangent),
    passing the disc on ``side`` (+1: counter-clockwise from a's direction)."""
    ca, cb = np.subtract(a, centre), np.subtract(b, centre)
    da, db = np.hypot(*ca), np.hypot(*cb)
    angle = (side * (math.atan2(cb[1], cb[0]) - math.atan2(ca[1], ca[0]))) % (2 * math.pi)
    arc = angle - math.acos(radius / da) - math.acos(radius / db)
    assert arc > 0  # the straight line is blocked
    return math.sqrt(da**2 - radius**2) + math.sqrt(db**2 - radius**2) + radius * arc


# -- free space ------------------------------------------------------------------------------


def test_grid_covers_the_drivable_area_and_frees_cells_by_clearance():
    layout = _layout(obstacles=[(1.0, 1.0, 0.4)], walls=[(-2.0, -1.0, 2.0, -1.0, 0.05)])
    grid = OccupancyGrid.from_layout(layout, 0.35, resolution=0.05)
    assert grid.shape == (120, 120)
    assert grid.bounds == pytest.approx(BOUNDS)
    assert not grid.free.flags.writeable
    cx, cy = np.meshgrid(grid.xs, grid.ys)
    centres = np.column_stack([cx.ravel(), cy.ravel()])
    expected = (layout.clearance(centres) > 0.35).reshape(grid.shape)
    np.testing.assert_array_equal(grid.free, expected)
    # cell centres: free exactly where the grid says so; outside the grid never
    np.testing.assert_array_equal(grid.is_free(centres), expected.ravel())
    outside = np.array([[3.01, 0.0], [0.0, -3.2], [10.0, 10.0]])
    assert not grid.is_free(outside).any()
    # the drivable area's edge belongs to free space (closed cells)
    assert grid.is_free(np.array([[3.0, 0.0], [-3.0, -3.0], [0.0, 3.0]])).all()


def test_a_resolution_that_does_not_divide_the_area_frees_only_centres_inside_it():
    grid = OccupancyGrid.from_layout(_layout(), 0.3, resolution=0.35)
    assert grid.shape == (18, 18)  # 6 / 0.35 = 17.1; the last centres lie at 3.125
    assert grid.bounds[1] == pytest.approx(-3.0 + 18 * 0.35)
    assert grid.free[:-1, :-1].all() and not grid.free[-1].any() and not grid.free[:, -1].any()
    fine = OccupancyGrid.from_layout(_layout(), 0.3, resolution=0.07)
    assert fine.shape == (86, 86) and fine.free.all()  # the last centres lie at 2.985


def test_clearance_is_the_distance_to_the_nearest_place_the_centre_may_not_be():
    grid = OccupancyGrid.from_layout(_layout(obstacles=[(1.0, 0.0, 0.4)]), 0.35)
    points = np.array([[-2.0, 0.0], [1.0, 2.0], [2.0, 0.0], [1.0, 0.0], [-2.9, 2.0], [3.5, 0.0]])
    np.testing.assert_allclose(
        grid.clearance(points), [1.0, min(1.0, 2.0 - 0.75), 0.25, -0.75, 0.1, -0.5]
    )
    assert np.all(OccupancyGrid.from_layout(_layout(), 0.35).clearance(np.zeros((2, 2))) == 3.0)


def test_line_of_sight_is_blocked_by_walls_and_free_along_their_faces():
    # a wall along x = 0 from y = -1 to the top, inflated to |x| <= 0.35 + 0.05
    grid = OccupancyGrid.from_layout(_layout(walls=[(0.0, -1.0, 0.0, 3.5, 0.05)]), 0.35)
    a = np.array([-1.0, 1.0])
    ends = np.array([[1.0, 1.0], [1.0, -2.0], [-1.0, -2.5], [-2.5, 2.5], [0.0, 1.0], [5.0, 1.0]])
    np.testing.assert_array_equal(
        grid.line_of_sight(a, ends), [False, False, True, True, False, False]
    )
    # along the face of the inflated wall (a grid line): free, a hair inside: blocked
    face = -0.4
    assert grid.line_of_sight([face, 2.5], np.array([[face, -0.5]]))[0]
    assert not grid.line_of_sight([face + 0.01, 2.5], np.array([[face + 0.01, -0.5]]))[0]
    assert grid.line_of_sight(a, np.zeros((0, 2))).shape == (0,)


@pytest.mark.parametrize("world", ["maze", "obstacles"])
def test_line_of_sight_by_rectangles_agrees_with_probing_every_cell(world, request):
    grid = request.getfixturevalue(world)
    rng = np.random.default_rng(1)
    u = grid._units(grid.sample_free(rng, 4000))
    corners = grid._graph.corners
    i, j = np.triu_indices(len(corners), 1)
    k = rng.integers(len(corners), size=2000)
    for a, b in [(u[:2000], u[2000:]), (corners[i], corners[j]), (u[:2000], corners[k])]:
        seen = grid._visible_units(a, b)
        np.testing.assert_array_equal(seen, grid._visible_probes(a, b))
        assert 0.1 < seen.mean() < 0.9


def test_a_pinch_blocks_sight_and_splits_components():
    free = np.ones((6, 6), dtype=bool)
    free[:3, :3] = False
    free[3:, 3:] = False  # the two blocked squares meet at the vertex (3, 3) only
    grid = OccupancyGrid(free, (0.0, 0.0), 1.0, (0.0, 6.0, 0.0, 6.0), 0.0, _layout())
    assert grid.n_components == 2
    assert not grid.is_free(np.array([[3.0, 3.0]]))[0]
    assert not grid.line_of_sight([1.0, 5.0], np.array([[5.0, 1.0]]))[0]
    assert grid.line_of_sight([1.0, 5.0], np.array([[2.5, 3.5]]))[0]
    assert math.isinf(grid.shortest_path_length([1.0, 5.0], [5.0, 1.0]))


# -- geodesic ------------------------------------------------------------------------------


def test_geodesic_equals_the_straight_line_in_the_open_arena():
    grid = OccupancyGrid.from_layout(_layout(), ROVER)
    rng = np.random.default_rng(0)
    points = rng.uniform(-3, 3, size=(200, 2))
    field = grid.geodesic(points[0])
    np.testing.assert_allclose(
        field.distance(points), np.linalg.norm(points - points[0], axis=1), rtol=0, atol=1e-9
    )
    for start in points[1:20]:
        assert grid.shortest_path_length(start, points[0]) == pytest.approx(
            np.linalg.norm(start - points[0]), abs=1e-9
        )
        np.testing.assert_allclose(field.path(start), [start, points[0]], atol=1e-12)


def test_geodesic_around_the_end_of_a_thin_wall_is_two_straight_legs():
    # a rover of radius 0 around a 0.1 m wall from (0, -1) to the top: via its end
    grid = OccupancyGrid.from_layout(_layout(walls=[(0.0, -1.0, 0.0, 3.5, 0.05)]), 0.0)
    a, b, end = np.array([-1.0, 1.0]), np.array([1.5, 2.0]), np.array([0.0, -1.05])
    legs = np.linalg.norm(a - end) + np.linalg.norm(end - b)
    got = grid.shortest_path_length(a, b)
    assert abs(got - legs) <= 1.5 * grid.resolution
    path = grid.geodesic(b).path(a)
    assert np.linalg.norm(path[:-1] - end, axis=1).min() <= 1.5 * grid.resolution


@pytest.mark.parametrize("radius", [0.2, ROVER])
@pytest.mark.parametrize("a, b", [((-1.5, -0.5), (1.5, -0.5)), ((-1.0, 2.0), (2.0, -2.0))])
def test_geodesic_around_the_inflated_end_of_a_wall_is_tangent_arc_tangent(radius, a, b):
    grid = OccupancyGrid.from_layout(_layout(walls=[(0.0, -1.0, 0.0, 3.5, 0.05)]), radius)
    exact = _wrap_length(a, b, (0.0, -1.0), radius + 0.05, side=1)
    got = grid.shortest_path_length(a, b)
    # The grown end's cells reach up to half a cell diagonal beyond the exact disc: the path is
    # longer by up to that times the angle it wraps (here 0.3-0.7 cells; a U-turn around the
    # end, 1.5). An 8-connected grid path would be several cells longer on these legs.
    assert -0.5 * grid.resolution <= got - exact <= 1.5 * grid.resolution, (got, exact)


def test_geodesic_around_a_post_hugs_the_grown_post():
    grid = OccupancyGrid.from_layout(_layout(obstacles=[(0.0, 0.0, 0.4)]), 0.35)
    a, b = np.array([-2.0, 0.0]), np.array([2.0, 0.0])
    exact = _wrap_length(a, b, (0.0, 0.0), 0.75, side=1)
    got = grid.shortest_path_length(a, b)
    assert abs(got - exact) <= 1.5 * grid.resolution
    path = grid.geodesic(b).path(a)
    assert np.all(np.linalg.norm(path, axis=1) >= 0.75 - grid.resolution)
    assert np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)) == pytest.approx(got)


@pytest.mark.parametrize("world", ["maze", "obstacles"])
def test_geodesic_equals_brute_force_over_all_corner_pairs(world, request):
    """The pruned graph and the best-first candidate search change nothing: the same distances
    as a visibility graph of all corner pairs, probed cell by cell, searched exhaustively."""
    grid = request.getfixturevalue(world)
    corners = grid._graph.corners
    i, j = np.triu_indices(len(corners), 1)
    seen = grid._visible_probes(corners[i], corners[j])
    weights = np.hypot(*(corners[i] - corners[j]).T)[seen]
    k = len(corners)
    between = csgraph.shortest_path(
        csr_matrix((weights, (i[seen], j[seen])), shape=(k, k)), directed=False
    )
    rng = np.random.default_rng(2)
    for goal in grid.sample_free(rng, 4):
        g = grid._units(goal[None])[0]
        leg = np.hypot(*(corners - g).T)
        to_goal = np.min(
            np.where(grid._visible_probes(np.broadcast_to(g, corners.shape), corners), leg, np.inf)
            + between,
            axis=1,
        )
        points = grid.sample_free(rng, 60)
        expected = []
        for p in grid._units(points):
            if grid._visible_probes(p[None], g[None])[0]:
                expected.append(np.hypot(*(p - g)))
                continue
            sees = grid._visible_probes(np.broadcast_to(p, corners.shape), corners)
            expected.append(np.min(np.where(sees, np.hypot(*(corners - p).T) + to_goal, np.inf)))
        field = grid.geodesic(goal)
        np.testing.assert_allclose(field.distance(points), np.array(expected) * grid.resolution)
        # one point at a time (the env's every step) gives the same answers
        one = [field.distance(p[None])[0] for p in points[:20]]
        np.testing.assert_allclose(one, field.distance(points[:20]))


def test_maze_paths_wrap_an_arm_end_and_are_free(maze):
    goal, start = np.array([2.5, 2.5]), np.array([-2.5, -2.5])  # opposite quadrants
    field = maze.geodesic(goal)
    assert not maze.line_of_sight(start, goal[None])[0]
    path = field.path(start)
    np.testing.assert_allclose(path[[0, -1]], [start, goal])
    length = np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))
    assert length == pytest.approx(field.distance(start[None])[0])
    assert np.linalg.norm(goal - start) * 1.1 < length < 9.0
    for p, q in zip(path[:-1], path[1:], strict=True):
        assert maze.line_of_sight(p, q[None])[0]
    # the path bends next to an arm's end (0, +-2) or (+-2, 0), not across the centre
    bends = path[1:-1]
    ends = np.array([[0.0, 2.0], [0.0, -2.0], [2.0, 0.0], [-2.0, 0.0]])
    assert np.linalg.norm(bends[:, None] - ends, axis=2).min() < 0.5


def test_points_outside_free_space_are_measured_from_the_nearest_free_cell(maze):
    field = maze.geodesic(np.array([2.5, 2.5]))
    inside = np.array([[1.0, 0.1], [3.2, 3.2]])  # in the inflated wall; beyond the grid
    assert not maze.is_free(inside).any()
    d = field.distance(inside)
    assert np.isfinite(d).all()
    for p, dist in zip(inside, d, strict=True):
        path = field.path(p)
        assert maze.is_free(path[1:2])[0]
        assert dist == pytest.approx(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))


def test_components_separate_what_a_wall_across_the_arena_divides():
    grid = OccupancyGrid.from_layout(_layout(walls=[(0.0, -3.5, 0.0, 3.5, 0.05)]), ROVER)
    assert grid.n_components == 2
    left, right = np.array([[-2.0, 0.0]]), np.array([[2.0, 0.0]])
    assert grid.component(left)[0] != grid.component(right)[0]
    assert grid.component(np.array([[0.0, 0.0]]))[0] == 0
    field = grid.geodesic(right[0])
    assert np.isinf(field.distance(left))[0]
    with pytest.raises(ValueError, match="cannot be reached"):
        field.path(left[0])
    rng = np.random.default_rng(0)
    same = grid.sample_free(rng, 100, component=int(grid.component(right)[0]))
    assert np.all(grid.component(same) == grid.component(right)[0])
    assert np.isfinite(field.distance(same)).all()


@pytest.mark.parametrize("name", ["paper_sim_obstacles", "paper_sim_maze"])
def test_shipped_navigation_worlds_leave_one_connected_free_space(name):
    spec = load_world_spec(name)
    for seed in range(5):
        grid = OccupancyGrid.from_layout(build_world(spec, seed).layout, ROVER)
        assert grid.n_components == 1, seed
        assert grid.free.mean() > 0.7


def test_sample_free_is_uniform_over_free_space_and_seeded(maze):
    a = maze.sample_free(np.random.default_rng(5), 4000)
    b = maze.sample_free(np.random.default_rng(5), 4000)
    np.testing.assert_array_equal(a, b)
    assert maze.is_free(a).all()
    # the plus is symmetric: each quadrant holds a quarter
    quadrant = (a[:, 0] > 0) * 2 + (a[:, 1] > 0)
    np.testing.assert_allclose(np.bincount(quadrant) / len(a), 0.25, atol=0.03)
    with pytest.raises(ValueError, match="component 7"):
        maze.sample_free(np.random.default_rng(0), 1, component=7)


def test_duck_typed_layouts_and_bad_arguments():
    layout = SimpleNamespace(bounds=BOUNDS, obstacles=((0.0, 0.0, 0.4),))
    grid = OccupancyGrid.from_layout(layout, 0.35)
    assert not grid.is_free(np.zeros((1, 2)))[0]
    with pytest.raises(ValueError, match="resolution"):
        OccupancyGrid.from_layout(layout, 0.35, resolution=0.0)
    with pytest.raises(ValueError, match="rover_radius"):
        OccupancyGrid.from_layout(layout, -0.1)
    with pytest.raises(ValueError, match=r"goal \(0\.0, 0\.0\) is not in free space"):
        grid.geodesic([0.0, 0.0])
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        grid.is_free(np.zeros(2))
    with pytest.raises(ValueError, match="finite"):
        grid.geodesic([2.0, 2.0]).distance(np.array([[np.nan, 0.0]]))
    assert isinstance(grid.geodesic([2.0, 2.0]), GeodesicField)


# -- single points ---------------------------------------------------------------------------


@pytest.mark.parametrize("world", ["open", "maze", "obstacles"])
def test_distance_at_one_point_agrees_with_the_array_query(world, request):
    grid = (
        OccupancyGrid.from_layout(_layout(), ROVER)
        if world == "open"
        else request.getfixturevalue(world)
    )
    rng = np.random.default_rng(1)
    field = grid.geodesic(grid.sample_free(rng, 1)[0])
    xmin, xmax, ymin, ymax = grid.bounds
    # inside and outside free space, and outside the grid (a rover pressed against a wall)
    points = rng.uniform((xmin - 0.2, ymin - 0.2), (xmax + 0.2, ymax + 0.2), size=(300, 2))
    single = [field.distance_at(x, y) for x, y in points]
    np.testing.assert_allclose(single, field.distance(points), rtol=0, atol=1e-12)
