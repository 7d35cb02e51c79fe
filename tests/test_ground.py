"""The ground by the date and the weather (sfa_gym.sim.worlds.ground): the lawn's calendar,
dry ground builds the world as drawn, wet ground and snow change the ground surfaces' materials
and nothing else, wet ground darkens and snow brightens the panorama below the horizon only."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from sfa_gym.sim import gl
from sfa_gym.sim.worlds import build_world, load_world_spec
from sfa_gym.sim.worlds.dynamics import DynamicsSpec
from sfa_gym.sim.worlds.ground import GroundLook, grass_greenness, ground_look_for
from sfa_gym.sim.worlds.textures import TexturesSpec

gl.configure()

GROUND_GEOMS = ("ground", "floor", "pavement", "road", "cycle_path")


@pytest.fixture(scope="module")
def spec():
    return load_world_spec("paper_outdoor")


@pytest.mark.parametrize(
    ("day", "latitude", "greenness"),
    [
        (15, 50.0, 0.0),  # winter: dormant
        (90, 50.0, 0.5),  # greening half way
        (196, 50.0, 1.0),  # summer
        (325, 50.0, 0.5),  # going dormant
        (196, -35.0, 0.0),  # July in the southern hemisphere: winter
        (15, -35.0, 1.0),
    ],
)
def test_the_lawns_calendar(day, latitude, greenness):
    assert grass_greenness(day, latitude) == pytest.approx(greenness, abs=1e-9)


def test_a_dormant_lawn_keeps_its_luminance_and_turns_from_green_to_straw():
    summer = np.array([0.25, 0.45, 0.15])
    dormant = GroundLook("dry", greenness=0.0).colour("grass", summer)
    luma = np.array([0.299, 0.587, 0.114])
    # the straw tint keeps about the summer colour's luminance, with red now above green's share
    assert dormant @ luma == pytest.approx(summer @ luma, rel=0.1)
    assert dormant[0] / dormant[1] > 1.0 > summer[0] / summer[1]


@pytest.mark.parametrize("textured", [False, True])
def test_dry_ground_and_a_summer_lawn_build_the_world_as_drawn(spec, textured):
    spec = dataclasses.replace(spec, textures=TexturesSpec() if textured else None)
    built = build_world(spec, 300).mjcf
    summer = dataclasses.replace(spec.dynamics, day_of_year=196, grass_seasons=True)
    assert ground_look_for(summer) is None
    assert build_world(spec, 300, dynamics=summer).mjcf == built


def _geoms(mjcf: str) -> list[str]:
    return re.findall(r"<geom [^>]*/>", mjcf)


@pytest.mark.parametrize("textured", [False, True])
@pytest.mark.parametrize("ground", ["wet", "snow"])
def test_wet_ground_and_snow_change_only_the_ground_surfaces_materials(spec, textured, ground):
    spec = dataclasses.replace(spec, textures=TexturesSpec() if textured else None)
    built = build_world(spec, 300)
    changed = build_world(spec, 300, dynamics=dataclasses.replace(spec.dynamics, ground=ground))
    assert changed.layout == built.layout
    before, after = _geoms(built.mjcf), _geoms(changed.mjcf)
    assert len(before) == len(after)
    no_material = re.compile(r' material="[^"]*"')
    names = [re.search(r'name="([^"]*)"', g) for g in before]
    on_ground = [n is not None and n.group(1) in GROUND_GEOMS for n in names]
    assert sum(on_ground) == len(GROUND_GEOMS)
    for old, new, ground_geom in zip(before, after, on_ground, strict=True):
        if ground_geom:  # same place and size; flat: another material, textured: new texels
            assert no_material.sub("", new) == no_material.sub("", old)
            assert textured or new != old, old
        else:
            assert new == old
    if textured:  # only the ground's textures were drawn again, every other byte is the same
        differ = {k for k in built.assets if built.assets[k] != changed.assets.get(k)}
        assert differ and all(re.search(rf'name="tex_{k[:-4]}"', built.mjcf) for k in differ), (
            differ
        )
        grounds = re.findall(r'<material name="(gen_(?:grass|asphalt|paving)\d+)"', built.mjcf)
        assert {f"{g}.png" for g in grounds} == differ


def test_the_same_day_gives_the_same_snow(spec):
    spec = dataclasses.replace(spec, textures=TexturesSpec())
    snow = dataclasses.replace(spec.dynamics, ground="snow")
    a, b = build_world(spec, 301, dynamics=snow), build_world(spec, 301, dynamics=snow)
    assert a.mjcf == b.mjcf and a.assets == b.assets


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"ground": "mud"}, r"ground must be one of \['dry', 'wet', 'snow'\], got 'mud'"),
        ({"grass_seasons": True}, "grass_seasons=True sets the lawn's colour by the date"),
        ({"grass_seasons": 1, "day_of_year": 10}, "grass_seasons must be True or False, got 1"),
    ],
)
def test_bad_ground_values_are_refused_by_name(change, match):
    with pytest.raises(ValueError, match=match):
        DynamicsSpec(**change)


def test_wet_ground_darkens_and_snow_brightens_the_panorama_below_the_horizon_only(spec):
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from sfa_gym.sim.camera import PanoramaSpec

    images = {}
    for ground in ("dry", "wet", "snow"):  # the same sun, no sensor: only the ground differs
        dynamics = dataclasses.replace(
            spec.dynamics, ground=ground, movers=False, clouds=False, clock=False
        )
        env = gym.make(
            "sfa_gym/OmniRoverOutdoor-v0",
            world_seed=300,
            dynamics=dynamics,
            textures=True,
            camera="cylindrical",
            mirror=None,
            sensor=False,
            panorama=PanoramaSpec(width=240, height=40),
        )
        obs, _ = env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})
        images[ground] = obs.astype(np.float64).mean(axis=2)
        env.close()
    dry, wet, snow = images["dry"], images["wet"], images["snow"]
    below = slice(len(dry) // 2 + 2, None)  # the camera looks level: the lower rows see ground
    above = slice(0, len(dry) // 2 - 8)  # sky, facades and crowns above the horizon
    assert wet[below].mean() < 0.8 * dry[below].mean()
    assert snow[below].mean() > 1.2 * dry[below].mean()
    for changed in (wet, snow):
        np.testing.assert_array_equal(changed[above], dry[above])
