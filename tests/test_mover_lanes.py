"""Movers keep to lanes that the outdoor scene keeps free: pedestrians on the pavement ring,
the cyclist and the cars on a road that passes the area on one side."""

from __future__ import annotations

import copy
import dataclasses
import json

import numpy as np
import pytest

from sfa_gym.sim import gl
from sfa_gym.sim.worlds import build_world, load_world_spec, world_spec_from_dict
from sfa_gym.sim.worlds.data import envs_dir
from sfa_gym.sim.worlds.dynamics import FOOTPRINT, Dynamics, DynamicsSpec, MoverSpec, RoadSpec

gl.configure()  # before mujoco is imported: later tests in the session render

import mujoco  # noqa: E402

_LOW = 1.5  # static geoms that reach below this height (m) are in a mover's way
_FLAT = 0.02  # geoms whose top lies below this height (m) are surfaces to walk or drive on


def _static_footprints(model, data):
    """``(n, 4)`` world-frame ``(xmin, xmax, ymin, ymax)`` of every static geom that stands
    in a mover's way (reaching below ``_LOW``, taller than a surface), and their names."""
    boxes, names = [], []
    for g in range(model.ngeom):
        if model.body_mocapid[model.geom_bodyid[g]] >= 0 or model.geom_bodyid[g] != 0:
            continue  # movers, and the rover's bodies
        kind = mujoco.mjtGeom(int(model.geom_type[g]))
        if kind == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        size, pos = model.geom_size[g], data.geom_xpos[g]
        rot = data.geom_xmat[g].reshape(3, 3)
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            half = np.abs(rot) @ size
        elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            half = np.full(3, size[0])
        elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
            half = np.abs(rot) @ size
        elif kind in (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE):
            # the axis is the geom's z: its extent along it, the radius across (a bound)
            axis = rot[:, 2]
            extra = size[0] if kind == mujoco.mjtGeom.mjGEOM_CAPSULE else 0.0
            half = np.abs(axis) * (size[1] + extra) + size[0] * np.sqrt(np.clip(1 - axis**2, 0, 1))
        else:
            raise AssertionError(f"geom type {kind} not handled")
        if pos[2] + half[2] < _FLAT or pos[2] - half[2] > _LOW:
            continue
        boxes.append((pos[0] - half[0], pos[0] + half[0], pos[1] - half[1], pos[1] + half[1]))
        names.append(model.geom(g).name)
    return np.array(boxes), names


def _mover_boxes(kind, path):
    """``(n, 4)`` world-frame bounding boxes of a mover's footprint along its ``path``."""
    a, b = FOOTPRINT[kind]
    c, s = np.abs(np.cos(path[:, 2])), np.abs(np.sin(path[:, 2]))
    if kind == "pedestrian":
        hx = hy = np.full(len(path), a)
    else:
        hx, hy = a * c + b * s, a * s + b * c
    x, y = path[:, 0], path[:, 1]
    return np.stack([x - hx, x + hx, y - hy, y + hy], axis=1)


def _overlap(movers, statics):
    """``(n, m)`` whether each mover box overlaps each static box (touching is clear)."""
    m, s = movers[:, None, :], statics[None, :, :]
    return (
        (m[..., 0] < s[..., 1])
        & (s[..., 0] < m[..., 1])
        & (m[..., 2] < s[..., 3])
        & (s[..., 2] < m[..., 3])
    )


def _world(seed, day=0, spec=None):
    spec = spec or load_world_spec("paper_outdoor")
    world = build_world(spec, seed)
    model = mujoco.MjModel.from_xml_string(world.mjcf)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    dyn = Dynamics(dataclasses.replace(spec.dynamics, day=day), model, spec.arena.size, seed,
                   world.lanes)  # fmt: skip
    return spec, world, model, data, dyn


def clearance_report(seed, day):
    """Per mover: kind, fraction of its path in static scenery, names hit, fraction on the
    asphalt."""
    spec, _, model, data, dyn = _world(seed, day)
    statics, names = _static_footprints(model, data)
    hx, hy = spec.arena.size[0] / 2, spec.arena.size[1] / 2
    asphalt = np.array([[-hx, hx, -hy, hy]])
    out = []
    for i, kind in enumerate(dyn.mover_kinds):
        boxes = _mover_boxes(kind, dyn.path(i))
        hits = _overlap(boxes, statics)
        on_asphalt = _overlap(boxes, asphalt)[:, 0]
        hit_names = sorted({names[j] for j in np.flatnonzero(hits.any(axis=0))})
        out.append((kind, hits.any(axis=1).mean(), hit_names, on_asphalt.mean(), len(boxes)))
    return out


@pytest.mark.parametrize("seed", range(8))
def test_every_mover_path_stays_clear_of_the_scenery_and_off_the_asphalt(seed):
    for day in range(3):
        for kind, in_scenery, hit, on_asphalt, n in clearance_report(seed, day):
            assert n > 100  # sampled densely: every 5 cm of a loop or a pass
            assert in_scenery == 0, (seed, day, kind, hit)
            assert on_asphalt == 0, (seed, day, kind)


def test_the_check_finds_a_mover_driven_through_a_parked_car():
    # the check itself can fail: a car lane moved onto the parked cars' side is caught
    spec, world, model, data, dyn = _world(0)
    statics, names = _static_footprints(model, data)
    cars = [j for j, n in enumerate(names) if n.startswith("car") and "_" not in n]
    assert cars and any(n.startswith("curb") for n in names)
    x0, x1, y0, y1 = statics[cars[0]]
    path = np.array([[(x0 + x1) / 2 + d, (y0 + y1) / 2, 0.0] for d in np.linspace(-5, 5, 50)])
    assert _overlap(_mover_boxes("car", path), statics).any()


def test_lanes_are_the_same_every_day_and_the_movers_too_for_a_seed_and_day():
    spec = load_world_spec("paper_outdoor")
    a, b = build_world(spec, 3), build_world(spec, 3)
    assert a.lanes == b.lanes and a.lanes is not None
    other_day = dataclasses.replace(spec, dynamics=dataclasses.replace(spec.dynamics, day=2))
    assert build_world(other_day, 3).lanes == a.lanes
    sides = {build_world(spec, s).lanes.road_side for s in range(8)}
    assert len(sides) >= 3  # the road's side comes from the world seed
    _, _, _, _, d1 = _world(3, day=1)
    _, _, _, _, d2 = _world(3, day=1)
    np.testing.assert_array_equal(d1.path(4), d2.path(4))


def test_road_movers_go_along_straight_lanes_beyond_the_pavement_and_come_and_go_far_away():
    spec, world, model, data, dyn = _world(1)
    lanes = world.lanes
    for i, kind in enumerate(dyn.mover_kinds):
        path = dyn.path(i)
        if kind == "pedestrian":
            # a loop round the pavement, between the curbs and the lamp posts
            d = np.maximum(np.abs(path[:, 0]) - 3.0, np.abs(path[:, 1]) - 4.0)
            assert 0.5 - 1e-9 <= d.min() and d.max() <= 0.85 + 1e-9
            continue
        across = path[:, 0] if lanes.road_side in ("east", "west") else path[:, 1]
        along = path[:, 1] if lanes.road_side in ("east", "west") else path[:, 0]
        assert np.ptp(across) < 1e-9 and np.ptp(path[:, 2]) < 1e-9  # straight, one heading
        assert np.ptp(along) > 0.99 * lanes.length
    # cyclists and cars come and go only far out, at the road's ends
    road = np.array([i for i, k in enumerate(dyn.mover_kinds) if k != "pedestrian"])
    mocap = [model.body_mocapid[model.body(f"mover{i}").id] for i in road]
    last_here, last_xy, changes = None, None, 0
    for t in np.arange(36000.0, 36000.0 + 900.0, 0.1):
        dyn.apply(data, t)
        here = dyn.movers_present(data)[road]
        xy = data.mocap_pos[mocap, :2].copy()
        if last_here is not None:
            for k in np.flatnonzero(here != last_here):
                # where it appeared, or where it was just before it went
                x, y = xy[k] if here[k] else last_xy[k]
                assert np.hypot(x, y) > lanes.length / 2 - 2.0, (road[k], t, x, y)
                changes += 1
        last_here, last_xy = here, xy
    assert changes >= 2


@pytest.mark.parametrize(
    "change, match",
    [
        ({"offset": [0.3, 0.8]}, r"pedestrian offsets \[0\.3, 0\.8\] m put them on the curbs"),
        ({"offset": [0.5, 1.2]}, r"put them on the curbs or the lamp posts"),
    ],
)
def test_pedestrian_offsets_off_the_walkway_are_refused_by_name(change, match):
    d = json.loads((envs_dir() / "paper_outdoor.json").read_text())
    d["dynamics"]["mover_kinds"][0].update(change)
    with pytest.raises(ValueError, match=match):
        build_world(world_spec_from_dict(d), 0)


def test_bad_road_values_are_refused_by_name():
    d = json.loads((envs_dir() / "paper_outdoor.json").read_text())
    bad = copy.deepcopy(d)
    bad["dynamics"]["road"]["distance"] = 1.0
    with pytest.raises(ValueError, match=r"road distance 1\.0 m puts the road on the pavement"):
        build_world(world_spec_from_dict(bad), 0)
    with pytest.raises(ValueError, match=r"road lane_width must be at least a car's width"):
        RoadSpec(lane_width=1.5)
    with pytest.raises(ValueError, match=r"road car_lanes must be an int >= 1, got 0"):
        RoadSpec(car_lanes=0)
    with pytest.raises(ValueError, match=r"a car keeps to the road's lanes.*offset"):
        MoverSpec("car", offset=(3.0, 4.0))
    with pytest.raises(ValueError, match=r"unknown key 'dynamics\.road\.lanes'"):
        world_spec_from_dict({"name": "w", "dynamics": {"road": {"lanes": 3}}})


def test_dynamics_with_another_road_than_the_worlds_is_refused():
    spec, world, model, data, dyn = _world(0)
    other = dataclasses.replace(spec.dynamics, road=RoadSpec(distance=4.0))
    with pytest.raises(ValueError, match="the world's road covers"):
        Dynamics(other, model, spec.arena.size, 0)
    assert Dynamics(DynamicsSpec(), model, spec.arena.size, 0).lanes == world.lanes


def test_cars_sharing_a_lane_keep_apart():
    spec = load_world_spec("paper_outdoor")
    kinds = tuple(
        dataclasses.replace(k, count=5) if k.kind == "car" else k for k in spec.dynamics.mover_kinds
    )
    spec = dataclasses.replace(spec, dynamics=dataclasses.replace(spec.dynamics, mover_kinds=kinds))
    _, _, model, data, dyn = _world(4, spec=spec)
    by_lane: dict[float, list[int]] = {}
    for i, kind in enumerate(dyn.mover_kinds):
        if kind == "car":
            by_lane.setdefault(dyn._movers[i].lane, []).append(i)
    assert sorted(len(v) for v in by_lane.values()) == [2, 3]
    together = 0
    for t in np.arange(0.0, 200.0, 0.25):
        dyn.apply(data, 36000.0 + t)
        present = dyn.movers_present(data)
        for same in by_lane.values():
            here = [i for i in same if present[i]]
            xy = np.array([data.mocap_pos[dyn._mocap[i]][:2] for i in here]).reshape(-1, 2)
            gaps = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1))
            gaps[np.diag_indices(len(here))] = np.inf
            assert len(here) < 2 or gaps.min() > 2 * 2.1  # never overlapping along the lane
            together += len(here) >= 2
    assert together > 100  # the check saw cars on one lane at once
