"""The campus world from above and from the rover.

    .venv/bin/python -m eval.studies.campus_figure [--out docs/campus.png] [--world-seed 0]

Writes one figure: the registered ``sfa_gym/OmniRoverCampus-v0`` world from straight above
(the two wings across the square, their footprints outlined, the paths at their alternating
ends), and the mirror
camera's 600 x 60 panorama (what every method sees; the camera's exposure and noise off) in the
south plaza, the middle court, the north plaza and the west path, each place marked on the
map. Backs docs/outdoor.md. Run from the repository root.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import tyro


@dataclass(frozen=True)
class Args:
    out: Path = Path("docs/campus.png")
    """the PNG file written"""
    world_seed: int = 0
    """the world drawn"""


PLACES = {
    "south plaza": (0.0, -10.0, 0.0),
    "middle court": (0.0, 0.0, 0.0),
    "north plaza": (0.0, 10.0, 0.0),
    "west path": (-8.75, -4.5, 0.0),
}
"""Where the rover stands for each panorama: ``(x, y, heading)`` (m, rad)."""


def main(args: Args) -> None:
    import gymnasium as gym
    from matplotlib.figure import Figure

    import sfa_gym  # noqa: F401  (registers the ids)

    env = gym.make(
        "sfa_gym/OmniRoverCampus-v0",
        world_seed=args.world_seed,
        sensor=False,
        dynamics={"movers": False},
        render_mode="rgb_array",
        render_size=500,
    )
    panoramas = {}
    for name, pose in PLACES.items():
        panoramas[name], _ = env.reset(seed=0, options={"pose": pose})
    top = env.render()
    view = env.unwrapped.view
    marks = {name: view.pixel([pose[:2]])[0] for name, pose in PLACES.items()}
    # the wings' footprints on the ground: seen in perspective, their roofs look wider
    footprints = [
        view.pixel([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)])
        for x0, x1, y0, y1 in env.unwrapped.layout.blocks
    ]
    env.close()

    fig = Figure(figsize=(11.0, 5.0), layout="constrained")
    grid = fig.add_gridspec(len(PLACES), 2, width_ratios=[1.0, 2.0])
    ax = fig.add_subplot(grid[:, 0])
    ax.imshow(top)
    for outline in footprints:
        ax.plot(outline[:, 1], outline[:, 0], "-", color="cyan", linewidth=1.0)
    for k, (row, col) in enumerate(marks.values()):
        ax.plot(col, row, "o", color="yellow", markersize=6, markeredgecolor="black")
        ax.annotate(
            str(k + 1),
            (col, row),
            xytext=(5, -5),
            textcoords="offset points",
            color="yellow",
            fontsize=9,
            fontweight="bold",
        )
    title = f"campus, world seed {args.world_seed}, from above (cyan: the wings' footprints)"
    ax.set_title(title, fontsize=8, loc="left")
    ax.set_axis_off()
    for k, (name, image) in enumerate(panoramas.items()):
        axp = fig.add_subplot(grid[k, 1])
        axp.imshow(image, interpolation="nearest")
        axp.set_title(f"{k + 1}: {name}, mirror camera 600 x 60", fontsize=8, loc="left")
        axp.set_axis_off()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1e3:.0f} kB)")


if __name__ == "__main__":
    main(tyro.cli(Args, description=__doc__.split("\n")[0]))
