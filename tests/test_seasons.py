"""The trees' foliage by the date (sfa_gym.sim.worlds.seasons): the phenology's calendar, a
summer date builds the world as drawn, a winter date changes nothing but the crowns' colour and
opacity, and the rendered panorama changes above the horizon only."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from sfa_gym.sim import gl
from sfa_gym.sim.worlds import build_world, load_world_spec
from sfa_gym.sim.worlds.dynamics import DynamicsSpec
from sfa_gym.sim.worlds.seasons import leaf_state
from sfa_gym.sim.worlds.textures import TexturesSpec

gl.configure()


@pytest.fixture(scope="module")
def spec():
    return load_world_spec("paper_outdoor")


def _dated(spec, day_of_year: int, **change) -> DynamicsSpec:
    return dataclasses.replace(spec.dynamics, day_of_year=day_of_year, seasons=True, **change)


@pytest.mark.parametrize(
    ("day", "latitude", "cover", "tint"),
    [
        (15, 50.0, 0.0, 0.0),  # winter: bare
        (120, 50.0, 0.5, 0.0),  # leaf-out half way
        (196, 50.0, 1.0, 0.0),  # summer
        (288, 50.0, 1.0, 0.8),  # autumn colours, leaves still on
        (315, 50.0, 0.2, 1.0),  # falling
        (350, 50.0, 0.0, 1.0),
        (196, -35.0, 0.0, 0.0),  # July in the southern hemisphere: winter
        (15, -35.0, 1.0, 0.0),  # January there: summer
    ],
)
def test_the_calendar_of_leaf_cover_and_autumn_tint(day, latitude, cover, tint):
    assert leaf_state(day, latitude) == pytest.approx((cover, tint), abs=1e-9)


@pytest.mark.parametrize("textured", [False, True])
def test_a_summer_date_builds_the_world_as_drawn(spec, textured):
    spec = dataclasses.replace(spec, textures=TexturesSpec() if textured else None)
    built = build_world(spec, 300).mjcf
    assert build_world(spec, 300, dynamics=_dated(spec, 196)).mjcf == built
    # without seasons the date moves the sun only: the world is as drawn
    unseasoned = dataclasses.replace(spec.dynamics, day_of_year=15)
    assert build_world(spec, 300, dynamics=unseasoned).mjcf == built


@pytest.mark.parametrize("day", [15, 288])
def test_another_date_changes_only_the_crowns(spec, day):
    def parts(mjcf: str) -> tuple[list[str], list[str]]:
        geoms = re.findall(r"<geom [^>]*/>", mjcf)
        crowns = [g for g in geoms if re.search(r'name="tree\d+_crown"', g)]
        rest = [g for g in geoms if g not in crowns]
        return [re.sub(r' material="[^"]*"', "", g) for g in crowns], rest

    built, dated = build_world(spec, 300), build_world(spec, 300, dynamics=_dated(spec, day))
    assert parts(dated.mjcf) == parts(built.mjcf)  # same places and sizes, all else the same
    assert dated.layout == built.layout
    assert dated.mjcf != built.mjcf
    materials = re.findall(r'name="tree\d+_crown"[^>]*material="([^"]*)"', dated.mjcf)
    rgba = [re.search(rf'<material name="{m}"[^>]*rgba="([^"]*)"', dated.mjcf) for m in materials]
    alphas = {float(r.group(1).split()[3]) for r in rgba}
    assert alphas == ({0.4} if day == 15 else {1.0})


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"seasons": True}, "seasons=True sets the foliage by the date: give a day_of_year"),
        ({"seasons": "yes", "day_of_year": 10}, "seasons must be True or False, got 'yes'"),
    ],
)
def test_bad_season_values_are_refused_by_name(change, match):
    with pytest.raises(ValueError, match=match):
        DynamicsSpec(**change)


def test_winter_changes_the_panorama_above_the_horizon_only(spec):
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from sfa_gym.sim.camera import PanoramaSpec

    images = []
    for seasons in (False, True):  # on the same date, under the same sun
        dynamics = _dated(spec, 15, movers=False, clouds=False, clock=False)
        env = gym.make(
            "sfa_gym/OmniRoverOutdoor-v0",
            world_seed=300,
            dynamics=dataclasses.replace(dynamics, seasons=seasons),
            camera="cylindrical",
            mirror=None,
            sensor=False,
            panorama=PanoramaSpec(width=240, height=40),
        )
        obs, _ = env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})
        images.append(obs.astype(np.int16))
        env.close()
    summer, winter = images  # the crowns as drawn, and bare (they cast no shadow)
    changed = np.abs(winter - summer).max(axis=2) > 8
    rows = changed.mean(axis=1)
    assert changed.mean() > 0.02
    # the camera looks level from below the crowns: the lower half sees the ground
    assert rows[len(rows) // 2 + 2 :].max() == 0.0, rows
