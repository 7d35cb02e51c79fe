"""The sun's cast shadows over a day: the textured outdoor world with and without them.

    .venv/bin/python -m eval.studies.shadows_figure [--out docs/outdoor_shadows.png]

Writes one figure: the rover standing in the arena of the textured outdoor world (the first
world seed of ``outdoor_appearance_textured``), a cylindrical panorama that looks down to the
ground around it, at three hours of one day, each without and with the sun's shadows
(``DynamicsSpec(shadows=True)``; clouds, movers and the camera's exposure off, so that the
shadows are the only difference); and the protocol's own mirror-camera panorama (what every
method sees) with shadows. Backs docs/outdoor.md. Run from the repository root.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import tyro


@dataclass(frozen=True)
class Args:
    out: Path = Path("docs/outdoor_shadows.png")
    """the PNG file written"""
    world_seed: int = 300
    """the world drawn (the track's first)"""
    hours: tuple[float, ...] = (8.5, 12.0, 16.5)
    """the times of day shown"""


POSE = (2.5, -3.5, 0.0)
"""Where the rover stands (x, y, heading): in a corner of the arena, near the trees and
buildings whose shadows reach it."""


def main(args: Args) -> None:
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from eval.studies.outdoor_figures import save_strip
    from sfa_gym.protocols.outdoor import ENV_ID
    from sfa_gym.sim.camera import PanoramaSpec

    wide = PanoramaSpec(width=900, height=110, vfov_deg=100.0)
    envs = {
        shadows: gym.make(
            ENV_ID,
            world_seed=args.world_seed,
            textures=True,
            camera="cylindrical",
            mirror=None,
            panorama=wide,
            sensor=False,
            dynamics={"clouds": False, "movers": False, "shadows": shadows},
        )
        for shadows in (False, True)
    }
    rows = []
    for hour in args.hours:
        for shadows, env in envs.items():
            obs, _ = env.reset(seed=0, options={"pose": POSE, "time_of_day": hour})
            rows.append((f"{hour:g} h, {'with' if shadows else 'without'} shadows", obs))
    for env in envs.values():
        env.close()
    mirror = gym.make(ENV_ID, world_seed=args.world_seed, textures=True, dynamics={"shadows": True})
    hour = args.hours[-1]
    obs, _ = mirror.reset(seed=0, options={"pose": POSE, "time_of_day": hour})
    mirror.close()
    rows.append((f"{hour:g} h, with shadows: the mirror camera's 600 x 60 panorama", obs))
    save_strip(rows, args.out, f"textured paper_outdoor seed {args.world_seed}", width=9.0)


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
