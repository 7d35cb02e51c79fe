"""The README's pictures of the outdoor world: a strip of panoramas, the mirror camera's circular
image and its unwarped panorama.

    .venv/bin/python -m eval.studies.outdoor_figures [--out docs] [--world-seed 0]

Writes ``outdoor_strip.png`` (cylindrical panoramas at the centre and two corners, then the
mirror camera at the centre, each at its time of day and with the movers where they are),
``mirror_circular.png`` and ``mirror_panorama.png``. Rerun it whenever the world changes.

Backs docs/outdoor.md (the pictures of the outdoor world). Run from the repository root.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro


@dataclass(frozen=True)
class Args:
    out: Path = Path("docs")
    """folder the PNG files are written to"""
    world_seed: int = 0
    """the world drawn"""
    hour: float = 10.2
    """time of day of the pictures, hours"""


POSES = (
    ("centre", (0.0, 0.0, 0.0)),
    ("south-west corner", (-2.3, -3.3, 0.0)),
    ("north-east corner", (2.3, 3.3, 0.0)),
)


def _panorama(env, pose: tuple[float, float, float], hour: float) -> np.ndarray:
    obs, _ = env.reset(seed=0, options={"pose": pose, "time_of_day": hour})
    return obs


def save_strip(
    rows: list[tuple[str, np.ndarray]],
    path: Path,
    prefix: str,
    height: float | None = None,
    interpolation: str = "nearest",
    width: float = 10.0,
) -> None:
    """Panoramas one above the other, each titled ``prefix, title``, in a figure ``width``
    inches wide (100 pixels each) and ``height`` high (None: each row at its own aspect, with
    room for its title); rows of other aspects get heights in proportion. Makes ``path``'s
    folder and says what it wrote."""
    if height is None:
        height = sum(width * image.shape[0] / image.shape[1] + 0.25 for _, image in rows)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    ratios = [image.shape[0] / image.shape[1] for _, image in rows]
    axes = fig.subplots(len(rows), 1, gridspec_kw={"height_ratios": ratios})
    for ax, (title, image) in zip(axes, rows, strict=True):
        ax.imshow(image, interpolation=interpolation)
        ax.set_title(f"{prefix}, {title}", fontsize=8, loc="left")
        ax.set_axis_off()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    print(f"wrote {path} ({path.stat().st_size / 1e3:.0f} kB)")


def main(args: Args) -> None:
    import gymnasium as gym
    from matplotlib.figure import Figure

    import sfa_gym  # noqa: F401  (registers the ids)

    args.out.mkdir(parents=True, exist_ok=True)
    common = {"world_seed": args.world_seed, "sensor": False}
    cylinder = gym.make("sfa_gym/OmniRoverOutdoor-v0", camera="cylindrical", mirror=None, **common)
    rows = [
        (f"cylindrical camera, {name}: x={p[0]:+.1f} m, y={p[1]:+.1f} m, yaw=0",
         _panorama(cylinder, p, args.hour))
        for name, p in POSES
    ]  # fmt: skip
    cylinder.close()
    mirror = gym.make("sfa_gym/OmniRoverOutdoor-v0", **common)
    rows.append(("mirror camera, unwarped, centre", _panorama(mirror, POSES[0][1], args.hour)))
    mirror.close()

    prefix = f"paper_outdoor seed {args.world_seed}, {args.hour:g} h"
    save_strip(rows, args.out / "outdoor_strip.png", prefix, 1.15 * len(rows))

    circular = gym.make("sfa_gym/OmniRoverOutdoor-v0", camera="mirror_circular", **common)
    image = _panorama(circular, POSES[0][1], args.hour)
    circular.close()
    fig = Figure(figsize=(4.0, 4.0), layout="constrained")
    ax = fig.subplots()
    ax.imshow(image)
    ax.set_title("mirror camera, circular image (480 x 480)", fontsize=8)
    ax.set_axis_off()
    fig.savefig(args.out / "mirror_circular.png", dpi=100)

    fig = Figure(figsize=(10.0, 1.3), layout="constrained")
    ax = fig.subplots()
    ax.imshow(rows[-1][1], interpolation="nearest")
    ax.set_title("the same, unwarped to 600 x 60 around a centre 2.5 px off", fontsize=8)
    ax.set_axis_off()
    fig.savefig(args.out / "mirror_panorama.png", dpi=100)
    print(f"wrote outdoor_strip.png, mirror_circular.png, mirror_panorama.png to {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args))
