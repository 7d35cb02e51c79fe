"""Motion blur: the textured outdoor world's mirror panorama while the rover turns in place at
its largest yaw rate, with instantaneous frames and with exposures of 1/250, 1/60 and 1/30 s,
and at dusk, when the auto-exposure's gain lengthens the exposure.

    .venv/bin/python -m eval.studies.motion_blur_figure [--out docs/motion_blur.png]

Writes one figure of a quarter of the 600 x 60 panorama (150 columns, drawn 4x), each row the
last frame of the same 10 steps of turning from the same pose and seed; only the sensor's
``exposure_s`` differs (``SensorSpec``, :mod:`sfa_gym.sim.camera.sensor`). Backs
docs/outdoor.md. Run from the repository root.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro


@dataclass(frozen=True)
class Args:
    out: Path = Path("docs/motion_blur.png")
    """the PNG file written"""
    world_seed: int = 300
    """the outdoor world drawn (the appearance track's first)"""
    columns: tuple[int, int] = (0, 150)
    """the part of the panorama's columns shown"""


def turned_frame(world_seed: int, exposure_s: float, hour: float) -> tuple[np.ndarray, float]:
    """The last of 10 frames while turning in place at ``w_max`` from the protocol's start,
    and the sensor's exposure for it, s (set by the gain before that frame)."""
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from sfa_gym.protocols.outdoor import ENV_ID
    from sfa_gym.sim.camera.sensor import SensorSpec

    env = gym.make(
        ENV_ID,
        world_seed=world_seed,
        textures=True,
        dynamics={"movers": False, "start_hour": hour},
        sensor=SensorSpec(noise=False, exposure_s=exposure_s),
    ).unwrapped
    env.reset(seed=0, options={"pose": (0.0, 0.0, 0.0)})
    turn = np.array([0.0, env.w_max], np.float32)
    for _ in range(9):
        env.step(turn)
    exposure = env._sensor.exposure(env.control_dt)
    frame = env.step(turn)[0]
    env.close()
    return frame, exposure


def main(args: Args) -> None:
    from eval.studies.outdoor_figures import save_strip

    lo, hi = args.columns
    rows = []
    # noon at four exposures, then dusk, where the auto-exposure's gain lengthens 1/60 s
    for exposure_s, hour in (
        (0.0, 12.0),
        (1 / 250, 12.0),
        (1 / 60, 12.0),
        (1 / 30, 12.0),
        (1 / 60, 19.5),
    ):
        frame, used = turned_frame(args.world_seed, exposure_s, hour)
        title = f"{hour:g} h, exposure_s {exposure_s:.4f}: {used * 1000:.1f} ms exposed"
        rows.append((title, np.repeat(np.repeat(frame[:, lo:hi], 4, 0), 4, 1)))
    save_strip(rows, args.out, "turning in place, commanded 1 rad/s", width=6.0)


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
