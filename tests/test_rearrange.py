"""Parked objects that change between days (sfa_gym.sim.worlds.rearrange): day 0 is the world as
built, another day changes only the parked cars and adds bins, benches and a building-site
fence beyond the pavement, the same day always gives the same world, and the protocol's
``rearranged`` condition reaches the rendered panoramas."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from sfa_gym.sim import gl
from sfa_gym.sim.worlds import build_world, load_world_spec
from sfa_gym.sim.worlds.dynamics import DynamicsSpec

gl.configure()

NEW_KINDS = {"bin", "bench", "site_fence"}
PARKED = {"car", *NEW_KINDS}


@pytest.fixture(scope="module")
def spec():
    return load_world_spec("paper_outdoor")


def _on(spec, **change) -> DynamicsSpec:
    return dataclasses.replace(spec.dynamics, **change)


def _geoms(mjcf: str) -> list[str]:
    return re.findall(r"<geom [^>]*/>", mjcf)


def _kind(geom: str) -> str:
    """ "car" for "car2_cabin", "site_fence" for "site_fence0_mesh"; "" without a name."""
    name = re.match(r'<geom (?:name="([^"]*)")?', geom).group(1) or ""
    return re.sub(r"\d.*$", "", name)


@pytest.mark.parametrize("seed", [0, 300])
def test_day_zero_and_a_share_of_zero_are_the_world_as_built(spec, seed):
    built = build_world(spec, seed).mjcf
    assert build_world(spec, seed, dynamics=_on(spec, arrangement=0)).mjcf == built
    assert build_world(spec, seed, dynamics=_on(spec, arrangement=3, rearrange_share=0.0)).mjcf == (
        built
    )


@pytest.mark.parametrize("seed", [0, 300, 301])
def test_another_day_changes_only_the_parked_objects(spec, seed):
    built = build_world(spec, seed)
    kept = [g for g in _geoms(built.mjcf) if _kind(g) != "car"]
    still = [lm for lm in built.layout.landmarks if lm[0] not in PARKED]
    changed = 0
    for day in (1, 2, 5):
        other = build_world(spec, seed, dynamics=_on(spec, arrangement=day))
        geoms = _geoms(other.mjcf)
        # everything but the parked objects is there, unchanged and in the same order
        assert [g for g in geoms if _kind(g) not in PARKED] == kept
        assert [lm for lm in other.layout.landmarks if lm[0] not in PARKED] == still
        changed += other.mjcf != built.mjcf
        # the same day is the same world
        assert build_world(spec, seed, dynamics=_on(spec, arrangement=day)).mjcf == other.mjcf
    assert changed == 3


def test_newcomers_stand_beyond_the_pavement_and_off_the_road(spec):
    hx, hy = (s / 2 + spec.outdoor.pavement_width for s in spec.arena.size)
    seen: set[str] = set()
    for day in range(1, 13):
        world = build_world(spec, 300, dynamics=_on(spec, arrangement=day))
        road = world.lanes.road_rect()
        for kind, x, y, _ in world.layout.landmarks:
            if kind not in NEW_KINDS:
                continue
            seen.add(kind)
            assert abs(x) > hx or abs(y) > hy, (kind, x, y)
            assert not (road[0] <= x <= road[1] and road[2] <= y <= road[3]), (kind, x, y)
    assert seen == NEW_KINDS  # a dozen days show every kind


def test_a_parked_car_stays_with_the_complement_of_the_share(spec):
    def cars(dynamics=None):
        world = build_world(spec, 300, dynamics=dynamics)
        return {(round(x, 6), round(y, 6)) for k, x, y, _ in world.layout.landmarks if k == "car"}

    home = cars()
    assert len(home) >= 2
    for share, expected in ((0.5, 0.5), (0.2, 0.8)):
        stayed = [
            len(home & cars(_on(spec, arrangement=d, rearrange_share=share))) / len(home)
            for d in range(1, 41)
        ]
        # 40 days x the row's cars: the mean's standard error is below 0.05
        assert abs(np.mean(stayed) - expected) < 0.15, (share, np.mean(stayed))


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"arrangement": -1}, "arrangement must be an integer >= 0"),
        ({"arrangement": True}, "arrangement must be an integer >= 0"),
        ({"arrangement": 1.5}, "arrangement must be an integer >= 0"),
        ({"rearrange_share": 1.5}, r"rearrange_share must lie in \[0, 1\], got 1.5"),
        ({"rearrange_share": "half"}, r"rearrange_share must lie in \[0, 1\], got 'half'"),
    ],
)
def test_bad_arrangement_values_are_refused_by_name(change, match):
    with pytest.raises(ValueError, match=match):
        DynamicsSpec(**change)


def test_the_rearranged_condition_changes_the_parked_objects_of_the_rendered_world():
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from sfa_gym.protocols.outdoor import ENV_ID, Config

    config = Config(panorama=(20, 200), conditions=("after", "rearranged"))
    kwargs = config.env_kwargs("rearranged", 300)
    assert kwargs["dynamics"].arrangement == 1
    still = {"clock": False, "movers": False, "clouds": False}
    panoramas, kinds = [], []
    for arrangement in (0, 1):
        dynamics = dataclasses.replace(kwargs["dynamics"], arrangement=arrangement, **still)
        env = gym.make(ENV_ID, **{**kwargs, "dynamics": dynamics})
        obs, _ = env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})
        panoramas.append(obs.astype(np.int16))
        kinds.append({k for k, *_ in env.unwrapped.layout.landmarks})
        env.close()
    assert not kinds[0] & NEW_KINDS and kinds[1] & NEW_KINDS
    changed = np.abs(panoramas[1] - panoramas[0]).max(axis=2) > 8
    # some things moved, most of the view did not
    assert 0.002 < changed.mean() < 0.3, changed.mean()
