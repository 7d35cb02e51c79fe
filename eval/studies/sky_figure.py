"""The cloud sky: the campus under the plain gradient sky, under clouds of two covers, the same
clouds' day four hours later, and overcast; and the outdoor protocol's own mirror-camera
panorama under the clouds.

    .venv/bin/python -m eval.studies.sky_figure [--out docs/outdoor_sky.png]

Writes one figure: the rover on the campus (its first world seed), a wide cylindrical panorama
(90 degrees high, so that the sky above 20 degrees shows), with
``DynamicsSpec(cloud_cover=...)`` (:mod:`sfa_gym.sim.worlds.sky`; movers off, the camera's
sensor on as in every run); the last row is the textured outdoor world's 600 x 60 mirror
panorama, whose sky reaches about 20 degrees above the horizon, where the clouds are
kilometres away and faint. Backs docs/outdoor.md. Run from the repository root.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import tyro


@dataclass(frozen=True)
class Args:
    out: Path = Path("docs/outdoor_sky.png")
    """the PNG file written"""
    world_seed: int = 500
    """the campus drawn (the campus track's first)"""
    hour: float = 10.0
    """the time of day of the clouds"""


CAMPUS_POSE = (6.0, 10.5, 0.0)
"""Where the rover stands on the campus (x, y, heading): in an open part, with sky in view."""


def main(args: Args) -> None:
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from eval.studies.outdoor_figures import save_strip
    from sfa_gym.protocols.outdoor import ENV_ID
    from sfa_gym.sim.camera import PanoramaSpec

    campus = "sfa_gym/OmniRoverCampus-v0"

    def seen(env_id: str, cover: float | None, hour: float, overcast: float = 0.0, **camera):
        pose = CAMPUS_POSE if env_id == campus else (0.0, 0.0, 0.0)
        probe = gym.make(env_id, world_seed=args.world_seed)
        base = probe.unwrapped.dynamics
        probe.close()
        dynamics = dataclasses.replace(
            base, movers=False, cloud_cover=cover, start_hour=hour, overcast=overcast
        )
        env = gym.make(env_id, world_seed=args.world_seed, dynamics=dynamics, **camera)
        obs, _ = env.reset(seed=0, options={"pose": pose})
        env.close()
        return obs

    wide = {"camera": "cylindrical", "mirror": None, "panorama": PanoramaSpec(600, 150, 90.0)}
    h = args.hour
    rows = [
        (f"campus, {h:g} h, the plain gradient sky", seen(campus, None, h, **wide)),
        (f"campus, {h:g} h, cloud_cover 0.3", seen(campus, 0.3, h, **wide)),
        (f"campus, {h:g} h, cloud_cover 0.6", seen(campus, 0.6, h, **wide)),
        (f"campus, {h + 4:g} h, cloud_cover 0.6: other clouds", seen(campus, 0.6, h + 4, **wide)),
        (f"campus, {h:g} h, cloud_cover 0.3, overcast 1", seen(campus, 0.3, h, 1.0, **wide)),
        (
            f"textured paper_outdoor, {h:g} h, cloud_cover 0.6, the protocol's mirror camera",
            seen(ENV_ID, 0.6, h, textures=True),
        ),
    ]
    save_strip(rows, args.out, f"world seed {args.world_seed}", width=5.6)


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
