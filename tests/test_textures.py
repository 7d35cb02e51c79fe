"""Generated surface textures: deterministic from the world seed, off by default (every shipped
world builds the MJCF it built before), valid PNG that MuJoCo loads texel for texel, and panoramas
whose amplitude spectrum falls less steeply than the flat world's."""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json

import gymnasium as gym
import numpy as np
import pytest

from sfa_gym.image_statistics import spectrum_slope
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.env import OmniRoverEnv, resolve_effect
from sfa_gym.sim.worlds import available_worlds, build_world, load_world_spec
from sfa_gym.sim.worlds.data import envs_dir
from sfa_gym.sim.worlds.spec import world_spec_from_dict
from sfa_gym.sim.worlds.textures import TexturesSpec, png_bytes
from sfa_gym.sim.worlds.texturing import SURFACES, Texturer

# sha256 of build_world(spec, seed).mjcf for world seeds 0 and 7 of every shipped spec,
# computed with the code before generated textures existed
BEFORE = {
    "paper_outdoor": (
        "7ed93c41d0de11f9feb14ef11d8dfd8c0cd9bd0225fdba1c0b86e04ba66a33a5",
        "54e85c87fab1bb72a82085bb5f2e061667b6f7a7078239d0aee29029f7a55e97",
    ),
    "paper_sim": (
        "2cfb8bdfd1877dc3a4b3f3a5e766a6d9be96b3af64808c27b3c9c50ed2adac25",
        "8256d24f9c2ffd713be0ab9aa8560d88f096fef363b7004f1ee05edb1ba0cd29",
    ),
    "paper_sim_maze": (
        "9b50f44bd3a8513e3fc399a93e01e50abf9127d503d23523499ad060e429b644",
        "3b17dc4706d24b109f9f832f4f78e5515e0f679d0db08340f34aeba92550c6c2",
    ),
    "paper_sim_obstacles": (
        "4acf7d9f2762bd9d080b54c3e5489d26d97d31da7910f2fee17170c47c0df503",
        "50a1d6258c035c19342426dee23771aca3023e12cfea5610b5a5aea24237d21b",
    ),
}


def _textured(name: str = "paper_outdoor", **settings):
    return dataclasses.replace(load_world_spec(name), textures=TexturesSpec(**settings))


AFTER_TEXTURES = {"campus"}
"""Worlds shipped after the textures came: they have no MJCF of before."""


def test_every_shipped_world_builds_the_mjcf_it_built_before_textures():
    assert sorted(BEFORE) == sorted(set(available_worlds()) - AFTER_TEXTURES)
    for name, hashes in BEFORE.items():
        spec = load_world_spec(name)
        assert spec.textures is None
        for seed, expected in zip((0, 7), hashes, strict=True):
            world = build_world(spec, seed)
            assert hashlib.sha256(world.mjcf.encode()).hexdigest() == expected, (name, seed)
            assert world.assets == {} and "gen_" not in world.mjcf


def test_textures_change_the_surfaces_and_nothing_else():
    flat = build_world(load_world_spec("paper_outdoor"), 3)
    textured = build_world(_textured(), 3)
    assert textured.mjcf != flat.mjcf
    assert textured.layout == flat.layout
    assert (
        set(textured.assets) == {f"{name}.png" for name in _texture_names(textured.mjcf)}
        and len(textured.assets) > 20
    )
    # the same geoms in the same places: only their materials differ
    strip = lambda mjcf: [  # noqa: E731
        " ".join(p for p in line.split() if not p.startswith("material="))
        for line in mjcf.splitlines()
        if line.strip().startswith("<geom")
    ]
    assert strip(textured.mjcf) == strip(flat.mjcf)
    for surface in ("asphalt", "grass", "paving", "concrete", "facade", "bark", "foliage", "bush"):
        assert f'material="gen_{surface}' in textured.mjcf, surface


def _texture_names(mjcf: str) -> set[str]:
    return {part.split('"')[1][: -len(".png")] for part in mjcf.split("file=")[1:]}


def test_same_world_seed_same_texture_bytes_other_seed_other_bytes():
    spec = _textured()
    a, b, c = build_world(spec, 5), build_world(spec, 5), build_world(spec, 6)
    assert a.mjcf == b.mjcf and a.assets == b.assets
    shared = set(a.assets) & set(c.assets)
    assert "gen_grass0.png" in shared
    assert all(a.assets[k] != c.assets[k] for k in shared)
    # each texture draws from its own generator: the same surface in another world differs
    one, other = Texturer(TexturesSpec(), 1), Texturer(TexturesSpec(), 2)
    grey = (0.3, 0.3, 0.3)
    assert np.array_equal(one.image("asphalt", "mat0", grey), one.image("asphalt", "mat0", grey))
    assert not np.array_equal(
        one.image("asphalt", "mat0", grey), other.image("asphalt", "mat0", grey)
    )


@pytest.mark.parametrize("surface", SURFACES)
def test_every_surface_keeps_its_material_colour_on_average(surface):
    rgb = (0.5, 0.35, 0.2)
    extra = {"glass": (0.2, 0.25, 0.3), "bays": (4, 3), "bay_m": (2.5, 3.0)}
    image = Texturer(TexturesSpec(resolution=64), 0).image(surface, "mat3", rgb, **extra)
    assert image.dtype == np.uint8 and image.shape in ((32, 32, 3), (64, 64, 3))
    assert image.std() > 2  # textured, not flat
    if surface != "facade":  # windows, frames and blinds move a facade's mean
        assert np.allclose(image.reshape(-1, 3).mean(axis=0) / 255, rgb, atol=0.05)


def test_png_bytes_load_in_mujoco_texel_for_texel():
    import mujoco

    image = np.random.default_rng(0).integers(0, 256, (8, 16, 3), dtype=np.uint8)
    xml = '<mujoco><asset><texture name="t" type="2d" file="t.png"/></asset><worldbody/></mujoco>'
    model = mujoco.MjModel.from_xml_string(xml, {"t.png": png_bytes(image)})
    assert (model.tex_height[0], model.tex_width[0]) == (8, 16)
    assert np.array_equal(model.tex_data[: image.size].reshape(image.shape), image)
    with pytest.raises(ValueError, match="uint8"):
        png_bytes(image.astype(np.float32))


def test_the_textured_world_compiles_from_its_assets():
    import mujoco

    world = build_world(_textured(resolution=64), 0)
    model = mujoco.MjModel.from_xml_string(world.mjcf, world.assets)
    names = {model.texture(i).name for i in range(model.ntex)}
    assert {f"tex_{n}" for n in _texture_names(world.mjcf)} <= names


def test_textured_panoramas_fall_less_steeply_than_flat_ones():
    slopes = {}
    for textures in (False, True):
        env = OmniRoverEnv(
            world="paper_outdoor",
            panorama=PanoramaSpec.paper_outdoor(),
            dynamics=False,
            textures=textures,
        )
        frames = np.stack([env.reset(seed=i)[0] for i in range(3)])
        env.close()
        slopes[textures] = spectrum_slope(frames).alpha
    assert slopes[True] < slopes[False] - 0.02, slopes


def test_the_textured_id_is_the_outdoor_id_with_textures():
    plain = gym.spec("sfa_gym/OmniRoverOutdoor-v0")
    textured = gym.spec("sfa_gym/OmniRoverOutdoorTextured-v0")
    assert textured.kwargs == {**plain.kwargs, "textures": True}
    assert textured.max_episode_steps == plain.max_episode_steps
    assert json.loads(json.dumps(textured.kwargs)) == textured.kwargs  # recordable


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"resolution": 100}, "power of two"),
        ({"resolution": 16}, "power of two"),
        ({"resolution": True}, "power of two"),
        ({"tile_m": 0.1}, "tile_m"),
        ({"tile_m": True}, "tile_m"),
        ({"tile_m": float("nan")}, "tile_m"),
        ({"cracks": -1}, "cracks"),
        ({"canopy_gaps": 0.95}, "canopy_gaps"),
        ({"canopy_gaps": "0.3"}, "canopy_gaps"),
    ],
)
def test_bad_texture_settings_are_refused_by_name(settings, message):
    with pytest.raises(ValueError, match=message):
        TexturesSpec(**settings)


def test_textures_need_an_outdoor_world_and_valid_keys():
    with pytest.raises(ValueError, match="textures need an outdoor block"):
        dataclasses.replace(load_world_spec("paper_sim"), textures=TexturesSpec())
    data = json.loads((envs_dir() / "paper_outdoor.json").read_text())
    with pytest.raises(ValueError, match="power of two"):
        world_spec_from_dict({**data, "textures": {"resolution": 48}})
    with pytest.raises(ValueError, match="unknown key.*resolutoin"):
        world_spec_from_dict({**data, "textures": {"resolutoin": 64}})
    data["textures"] = {"resolution": 64}
    assert world_spec_from_dict(data).textures == TexturesSpec(resolution=64)


def test_the_env_switch():
    spec = load_world_spec("paper_outdoor")

    def chosen(world, textures):
        return resolve_effect("textures", textures, TexturesSpec, world.textures)

    assert chosen(spec, None) is spec.textures
    assert chosen(spec, True) == TexturesSpec()
    assert chosen(_textured(resolution=64), True) == TexturesSpec(resolution=64)
    assert chosen(_textured(), False) is None
    assert chosen(_textured(resolution=64), {"resolution": 32}) == TexturesSpec(resolution=32)
    with pytest.raises(TypeError, match="textures must be None, a bool, a TexturesSpec or an"):
        chosen(spec, "yes")
    with pytest.raises(ValueError, match="outdoor block"):
        OmniRoverEnv(world="paper_sim", textures=True)


def test_png_is_a_valid_image_file():
    from PIL import Image

    image = np.arange(4 * 5 * 3, dtype=np.uint8).reshape(4, 5, 3)
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(png_bytes(image)))), image)
