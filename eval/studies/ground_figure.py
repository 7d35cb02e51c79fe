"""The ground through the year and the weather: the textured outdoor world's lawn, asphalt and
pavements dry, wet and under snow, and the lawn in summer and dormant in winter.

    .venv/bin/python -m eval.studies.ground_figure [--out docs/outdoor_ground.png]

Writes one figure: the rover standing in the arena of the textured outdoor world (the first
world seed of ``outdoor_appearance_textured``), a cylindrical panorama that looks down to the
ground around it, at noon on a mid-July day (ground dry and wet) and on a mid-January day
(ground dry and under snow; 50 degrees north, the trees' foliage and the lawn by the date)
(``DynamicsSpec(ground=..., grass_seasons=True, seasons=True)``; clouds and movers off, the
camera's sensor on as in every run); and the protocol's own mirror-camera panorama in the
snow. Backs docs/outdoor.md. Run from the repository root.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import tyro


@dataclass(frozen=True)
class Args:
    out: Path = Path("docs/outdoor_ground.png")
    """the PNG file written"""
    world_seed: int = 300
    """the world drawn (the track's first)"""
    summer: int = 196
    """the summer day of the year (dry and wet ground)"""
    winter: int = 15
    """the winter day of the year (dry ground and snow)"""
    hour: float = 12.0
    """the time of day"""


POSE = (2.5, -3.5, 0.0)
"""Where the rover stands (x, y, heading): in a corner of the arena, with lawn, pavement and
asphalt in view."""


def main(args: Args) -> None:
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from eval.studies.outdoor_figures import save_strip
    from sfa_gym.protocols.outdoor import ENV_ID
    from sfa_gym.sim.camera import PanoramaSpec
    from sfa_gym.sim.worlds.spec import load_world_spec

    base = dataclasses.replace(
        load_world_spec("paper_outdoor").dynamics,
        clouds=False,
        movers=False,
        day_of_year=args.summer,
        seasons=True,
        grass_seasons=True,
    )

    def seen(day: int, ground: str, **camera: object) -> object:
        dynamics = dataclasses.replace(base, day_of_year=day, ground=ground)
        env = gym.make(
            ENV_ID, world_seed=args.world_seed, textures=True, dynamics=dynamics, **camera
        )
        obs, _ = env.reset(seed=0, options={"pose": POSE, "time_of_day": args.hour})
        env.close()
        return obs

    wide = {"camera": "cylindrical", "mirror": None, "panorama": PanoramaSpec(900, 110, 100.0)}
    days = ((args.summer, "dry"), (args.summer, "wet"), (args.winter, "dry"), (args.winter, "snow"))
    rows = [(f"day {d}, {args.hour:g} h, ground {g}", seen(d, g, **wide)) for d, g in days]
    mirror = seen(args.winter, "snow")
    rows.append((f"day {args.winter}, snow: the mirror camera's 600 x 60 panorama", mirror))
    save_strip(rows, args.out, f"textured paper_outdoor seed {args.world_seed}", width=9.0)


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
