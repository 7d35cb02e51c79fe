"""The outdoor world flat and with its generated textures, at the same poses and time of day.

    .venv/bin/python -m eval.studies.textured_figure [--out docs/textured_outdoor.png] \
        [--world-seed 0]

Writes one figure: a detailed cylindrical panorama (1800 x 180) at the centre, flat then
textured, then the observations of the registered ids (600 x 60: the cylindrical camera at two
corners, the mirror camera at the centre), each flat then textured. The camera's noise is off so
that the surfaces show. Backs docs/outdoor.md (generated textures). Run from the repository root.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro


@dataclass(frozen=True)
class Args:
    out: Path = Path("docs/textured_outdoor.png")
    """the PNG file written"""
    world_seed: int = 0
    """the world drawn"""
    hour: float = 10.2
    """time of day of the pictures, hours"""


CENTRE = (0.0, 0.0, 0.0)
CORNERS = (("south-west corner", (-2.3, -3.3, 0.0)), ("north-east corner", (2.3, 3.3, 1.0)))


def _panorama(env, pose: tuple[float, float, float], hour: float) -> np.ndarray:
    obs, _ = env.reset(seed=0, options={"pose": pose, "time_of_day": hour})
    return obs


def main(args: Args) -> None:
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)
    from eval.studies.outdoor_figures import save_strip
    from sfa_gym.sim.camera import PanoramaSpec

    common = {"world_seed": args.world_seed, "sensor": False}
    cylinder = {"camera": "cylindrical", "mirror": None}
    rows = []
    for textures in (False, True):
        kind = "textured" if textures else "flat"
        env = gym.make(
            "sfa_gym/OmniRoverOutdoor-v0",
            panorama=PanoramaSpec(1800, 180, vfov_deg=40.0),
            textures=textures,
            **cylinder,
            **common,
        )
        rows.append((f"{kind}, cylindrical 1800 x 180, centre", _panorama(env, CENTRE, args.hour)))
        env.close()
    for name, pose in CORNERS:
        for textures in (False, True):
            kind = "textured" if textures else "flat"
            env = gym.make("sfa_gym/OmniRoverOutdoor-v0", textures=textures, **cylinder, **common)
            rows.append((f"{kind}, cylindrical 600 x 60, {name}", _panorama(env, pose, args.hour)))
            env.close()
    for textures in (False, True):
        kind = "textured" if textures else "flat"
        env = gym.make("sfa_gym/OmniRoverOutdoor-v0", textures=textures, **common)
        rows.append((f"{kind}, mirror camera 600 x 60, centre", _panorama(env, CENTRE, args.hour)))
        env.close()

    height = sum(10.0 * image.shape[0] / image.shape[1] + 0.25 for _, image in rows)
    prefix = f"paper_outdoor seed {args.world_seed}, {args.hour:g} h"
    save_strip(rows, args.out, prefix, height, interpolation="antialiased")


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
