"""The textured outdoor world under each test condition of the appearance tracks, and by season.

    .venv/bin/python -m eval.studies.conditions_figure [--out docs/outdoor_conditions.png]

Writes one figure: the rover at the arena's centre, its mirror camera's 600 x 60 panorama (what
every method sees) at the start of the test runs of ``outdoor_appearance_textured`` (the
protocol's own env settings, :meth:`sfa_gym.protocols.outdoor.Config.env_kwargs`): after the
training run, 4 h later, overcast, without movers, another day, in thick fog and with the
parked objects of another day (the conditions ``fog`` and ``rearranged``, on no track yet);
then the same world on a mid-January, a mid-July and a mid-October day at the training hour,
the trees' foliage by the date, and the evening with the camera's auto white balance and
vignetting. Backs docs/outdoor.md. Run from the repository root.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro


@dataclass(frozen=True)
class Args:
    out: Path = Path("docs/outdoor_conditions.png")
    """the PNG file written"""
    world_seed: int = 300
    """the world drawn (the track's first)"""


CENTRE = {"pose": (0.0, 0.0, 0.0)}


def _panorama(kwargs: dict) -> np.ndarray:
    import gymnasium as gym

    from sfa_gym.protocols.outdoor import ENV_ID

    env = gym.make(ENV_ID, **kwargs)
    obs, _ = env.reset(seed=0, options=CENTRE)
    env.close()
    return obs


def main(args: Args) -> None:
    import sfa_gym  # noqa: F401  (registers the ids)
    from eval.studies.outdoor_figures import save_strip
    from sfa_gym.leaderboard.tracks import default_track_folder, load_track

    track = load_track(default_track_folder() / "outdoor_appearance_textured.json")
    config = track.config(False)
    rows = []
    for condition in ("after", *config.test_conditions):
        kwargs = config.env_kwargs(condition, args.world_seed)
        if condition == "after":  # the test part starts the training frames later
            kwargs["start_hour"] = config.start_hour + config.train_frames * config.frame_dt / 3600
        hour = kwargs["start_hour"]
        rows.append((f"{condition}, {hour:.2f} h", _panorama(kwargs)))
    foggy = dataclasses.replace(config, conditions=(*config.conditions, "fog"))
    kwargs = foggy.env_kwargs("fog", args.world_seed)
    title = f"fog (visibility {foggy.fog_visibility_m:g} m, overcast), {kwargs['start_hour']:.2f} h"
    rows.append((title, _panorama(kwargs)))
    moved = dataclasses.replace(config, conditions=(*config.conditions, "rearranged"))
    kwargs = moved.env_kwargs("rearranged", args.world_seed)
    title = f"rearranged (the parked objects of arrangement day 1), {kwargs['start_hour']:.2f} h"
    rows.append((title, _panorama(kwargs)))
    for day_of_year, name in ((15, "mid-January"), (196, "mid-July"), (288, "mid-October")):
        dated = dataclasses.replace(config, day_of_year=day_of_year, seasons=True)
        rows.append(
            (
                f"{name}, {config.start_hour:g} h, seasons",
                _panorama(dated.env_kwargs("after", args.world_seed)),
            )
        )
    evening = dataclasses.replace(config, start_hour=18.5)
    for white_balance, vignetting in ((False, 0.0), (True, 0.3)):
        camera = dataclasses.replace(evening, white_balance=white_balance, vignetting=vignetting)
        title = "18.5 h" + (", auto white balance, vignetting 0.3" if white_balance else "")
        rows.append((title, _panorama(camera.env_kwargs("after", args.world_seed))))
    # 6 inches: the panoramas' own 600 columns, no pixel repeated
    save_strip(rows, args.out, f"textured paper_outdoor seed {args.world_seed}", width=6.0)


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
