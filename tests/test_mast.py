"""The sprung camera mast: the rigid default model is unchanged, the outdoor preset's camera
tilts at a hard stop and settles, the panorama follows the tilt, and bad values are refused."""

from __future__ import annotations

import dataclasses
import hashlib
import math

import numpy as np
import pytest

from sfa_gym.sim import gl

gl.configure()

import mujoco  # noqa: E402

from sfa_gym.sim.camera import PanoramaSpec  # noqa: E402
from sfa_gym.sim.env import OmniRoverEnv  # noqa: E402
from sfa_gym.sim.rover import WHEELS, RoverSpec, rover_mjcf  # noqa: E402
from sfa_gym.sim.worlds import build_world, load_world_spec  # noqa: E402

# sha256 of assets + NUL + worldbody + NUL + actuators of rover_mjcf(RoverSpec(), paper_sim),
# computed before the sprung mast existed: the rigid model must stay byte-identical.
RIGID_MJCF_SHA256 = "9e20a0906a0a92a8dc3e55b5ad396336038a66b8dc4d65f0ffebc7f9607bb287"
SMALL = PanoramaSpec(width=120, height=16)


def _digest(spec: RoverSpec, panorama: PanoramaSpec) -> str:
    parts = rover_mjcf(spec, panorama)
    text = "\x00".join([parts.assets, parts.worldbody, parts.actuators])
    return hashlib.sha256(text.encode()).hexdigest()


def _tilt_deg(data: mujoco.MjData, body: int) -> float:
    """Angle between the camera body's z axis and the world vertical, degrees."""
    up = data.xmat[body].reshape(3, 3)[:, 2]
    return math.degrees(math.acos(min(1.0, float(up[2]))))


def _stop_tilts(spec: RoverSpec) -> tuple[float, float]:
    """Drive straight at 0.4 m/s for 3 s, then command a stop. Returns the largest camera
    tilt in the 2 s after the stop and the largest in the 0.5 s after that (degrees)."""
    built = build_world(load_world_spec("paper_sim"), 0, rover_mjcf(spec, SMALL))
    model = mujoco.MjModel.from_xml_string(built.mjcf)
    data = mujoco.MjData(model)
    camera = model.body("rover_camera").id
    actuators = [model.actuator(f"rover_drive_{w}").id for w in WHEELS]
    steps_per_second = round(1.0 / model.opt.timestep)

    def run(v: float, seconds: float) -> list[float]:
        left, right = spec.wheel_speeds(v, 0.0)
        data.ctrl[actuators] = (left, left, right, right)
        tilts = []
        for _ in range(round(seconds * steps_per_second)):
            mujoco.mj_step(model, data)
            tilts.append(_tilt_deg(data, camera))
        return tilts

    run(0.0, 1.0)  # settle on the tyres
    run(0.4, 3.0)
    after_stop = run(0.0, 2.0)
    late = run(0.0, 0.5)
    return max(after_stop), max(late)


def test_default_rover_mjcf_is_byte_identical_to_the_rigid_model():
    assert _digest(RoverSpec(), PanoramaSpec.paper_sim()) == RIGID_MJCF_SHA256
    # 0 is a rigid mast too
    assert _digest(RoverSpec(mast_stiffness=0.0), PanoramaSpec.paper_sim()) == RIGID_MJCF_SHA256
    assert "rover_mast_pitch" not in rover_mjcf(RoverSpec(), SMALL).worldbody
    assert not RoverSpec().sprung_mast


def test_outdoor_preset_hangs_the_camera_on_two_sprung_hinges():
    spec = RoverSpec.outdoor()
    assert spec.sprung_mast and spec.mast_stiffness > spec.mast_gravity_moment
    built = build_world(load_world_spec("paper_sim"), 0, rover_mjcf(spec, SMALL))
    model = mujoco.MjModel.from_xml_string(built.mjcf)
    mast = model.body("rover_mast").id
    assert model.body("rover_camera").parentid[0] == mast
    for name, axis in (("rover_mast_pitch", (0, 1, 0)), ("rover_mast_roll", (1, 0, 0))):
        joint = model.joint(name)
        assert joint.bodyid[0] == mast
        np.testing.assert_array_equal(joint.axis, axis)
        assert model.jnt_stiffness[joint.id] == spec.mast_stiffness
        assert model.dof_damping[joint.dofadr[0]] == spec.mast_damping
    # the camera head's mass swings with the mast
    assert model.body_mass[model.body("rover_camera").id] == pytest.approx(spec.camera_mass)


def test_hard_stop_tilts_the_sprung_camera_and_it_settles():
    peak, late = _stop_tilts(RoverSpec.outdoor())
    assert 0.5 < peak < 15.0
    assert late < 0.2
    rigid_peak, _ = _stop_tilts(RoverSpec())
    # the spring adds its own swing to the chassis' rocking on the tyres
    assert peak > rigid_peak + 0.3


def test_panorama_follows_the_mast_tilt_and_yaw_comes_from_the_chassis():
    env = OmniRoverEnv(panorama=SMALL, rover=RoverSpec.outdoor())
    try:
        level, info = env.reset(seed=0, options={"pose": (0.0, 0.0, 0.5)})
        pitch = env.model.joint("rover_mast_pitch")
        env.data.qpos[pitch.qposadr[0]] = math.radians(8.0)
        mujoco.mj_forward(env.model, env.data)
        tilted = env._observe(None)
        # a tilted camera sees the horizon move: the picture changes, the pose does not
        diff = np.abs(tilted.astype(np.int16) - level.astype(np.int16)).mean()
        assert diff > 2.0
        assert env._info()["yaw"] == pytest.approx(info["yaw"])
        assert info["yaw"] == pytest.approx(0.5, abs=1e-6)
    finally:
        env.close()


@pytest.mark.parametrize(
    ("changes", "error", "match"),
    [
        ({"mast_stiffness": -1.0}, ValueError, "mast_stiffness must be zero or positive"),
        ({"mast_stiffness": math.nan}, ValueError, "mast_stiffness must be finite"),
        ({"mast_stiffness": "stiff"}, TypeError, "mast_stiffness must be a number"),
        ({"mast_stiffness": True}, TypeError, "mast_stiffness must be a number"),
        ({"mast_stiffness": 2.0}, ValueError, "cannot hold the mast up"),
        ({"mast_damping": 1.0}, ValueError, "mast_damping=1.0 needs a sprung mast"),
        ({"mast_stiffness": 60.0, "mast_damping": -0.1}, ValueError, "mast_damping must be"),
        ({"camera_mass": 0.0}, ValueError, "camera_mass must be positive"),
        ({"camera_mass": math.inf}, ValueError, "camera_mass must be finite"),
    ],
)
def test_bad_mast_values_are_refused(changes, error, match):
    with pytest.raises(error, match=match):
        dataclasses.replace(RoverSpec(), **changes)


def test_rover_preset_names_reach_the_env_and_the_registered_outdoor_id():
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)

    assert OmniRoverEnv(panorama=SMALL, rover="outdoor").rover == RoverSpec.outdoor()
    assert OmniRoverEnv(panorama=SMALL, rover="default").rover == RoverSpec()
    assert OmniRoverEnv(panorama=SMALL).rover.mast_stiffness is None
    env = gym.make("sfa_gym/OmniRoverOutdoor-v0")
    try:
        assert env.unwrapped.rover == RoverSpec.outdoor()
        assert "rover_mast_pitch" in env.unwrapped.mjcf
    finally:
        env.close()


@pytest.mark.parametrize(
    ("rover", "error", "match"),
    [
        ("wobbly", ValueError, r"unknown rover preset 'wobbly'.*\['default', 'outdoor'\]"),
        (60.0, TypeError, "rover must be a RoverSpec, a preset name or None, got 60.0"),
    ],
)
def test_bad_rover_values_are_refused(rover, error, match):
    with pytest.raises(error, match=match):
        OmniRoverEnv(panorama=SMALL, rover=rover)
