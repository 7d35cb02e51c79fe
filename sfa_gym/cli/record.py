"""``sfa-gym record``: drive the rover along a scripted trajectory and record the run, with a
panorama strip and a trajectory plot next to it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_finite, check_int, check_positive_int
from sfa_gym.protocols.settings import EnvId, check_choice, check_env_id

__all__ = ["Record", "panorama_strip"]

DriverName = Literal["lawnmower", "loop", "randomwalk", "grid"]


@dataclass(frozen=True)
class Record:
    """Record a run of the rover along a scripted trajectory."""

    out: Path
    """run directory, ending in .run (created; an incomplete run there with the same settings is
    resumed)"""
    env_id: EnvId = "sfa_gym/OmniRover-v0"
    """registered env to drive in"""
    driver: DriverName = "lawnmower"
    """trajectory: "lawnmower" (rows at spacing, turns on the spot), "loop" (rectangular loops
    along the walls), "randomwalk" (needs steps) or "grid" (the grid protocol's positions)"""
    steps: int | None = None
    """samples to record (None: until the driver is done)"""
    seed: int = 0
    """seed of the env resets and the driver"""
    world_seed: int = 0
    """seed of the world's procedural variation"""
    spacing: float = 0.5
    """lawnmower: distance between the rows, m"""
    spin: float = 0.0
    """lawnmower: extra rotation on the spot at each row end, rad"""
    turn_probability: float = 0.5
    """randomwalk: probability that a new segment is a turn on the spot"""
    grid: int = 30
    """grid: positions per side"""
    overwrite: bool = False
    """replace an existing run instead of resuming it"""
    quiet: bool = False
    """no progress bar"""

    def validate(self) -> None:
        """Raise ValueError naming the first bad setting.

        The recorder checks the rest (the run directory, ``steps``, the driver's options against
        the env's arena) before it writes anything.
        """
        check_env_id("env_id", self.env_id)
        check_choice("driver", self.driver, DriverName)
        for name in ("seed", "world_seed"):
            check_int(name, getattr(self, name))
        for name in ("spacing", "spin", "turn_probability"):
            check_finite(name, getattr(self, name))
        check_positive_int("grid", self.grid)

    def make_driver(self) -> Any:
        """The driver (or grid of poses) named by ``driver``, with its options."""
        from sfa_gym.recording import drivers

        if self.driver == "lawnmower":
            return drivers.LawnMowerDriver(spacing=self.spacing, spin=self.spin)
        if self.driver == "loop":
            return drivers.LoopDriver()
        if self.driver == "randomwalk":
            return drivers.RandomWalkDriver(turn_probability=self.turn_probability)
        return drivers.GridPositions(n=self.grid, seed=self.seed, order="hilbert")

    def run(self) -> int:
        """Validate, record, and write ``<name>_panoramas.png`` and ``<name>_trajectory.png``."""
        from sfa_gym.localization.plots import trajectory
        from sfa_gym.recording.recorder import record

        self.validate()
        out = Path(self.out)
        run = record(
            self.env_id,
            self.make_driver(),
            out,
            n_steps=self.steps,
            seed=self.seed,
            env_kwargs={"world_seed": self.world_seed},
            overwrite=self.overwrite,
            progress=not self.quiet,
        )
        strip = out.with_name(out.stem + "_panoramas.png")
        _save_png(strip, panorama_strip(run.panoramas))
        bounds = run.metadata.get("arena_bounds")
        fig, _ = trajectory(run.poses, bounds=tuple(bounds) if bounds else None)
        plot = out.with_name(out.stem + "_trajectory.png")
        fig.savefig(plot, dpi=110, bbox_inches="tight")
        print(f"recorded {len(run)} samples into {out}")
        print(f"wrote {strip} and {plot}")
        return 0


def panorama_strip(panoramas: Any, n: int = 8) -> NDArray[np.uint8]:
    """``n`` panoramas ``(H, W, 3)`` evenly spaced over a run, stacked top to bottom with 2 px
    white gaps: ``(n H + 2 (n - 1), W, 3)`` uint8 (fewer for a shorter run)."""
    idx = np.unique(np.linspace(0, len(panoramas) - 1, n).round().astype(int))
    rows = []
    for i in idx:
        rows.append(np.asarray(panoramas[int(i)]))
        rows.append(np.full((2, rows[-1].shape[1], 3), 255, dtype=np.uint8))
    return np.concatenate(rows[:-1])


def _save_png(path: Path, rgb: NDArray[np.uint8], scale: int = 2) -> None:
    import cv2

    big = cv2.resize(rgb, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    if not cv2.imwrite(str(path), cv2.cvtColor(big, cv2.COLOR_RGB2BGR)):
        raise OSError(f"could not write {path}")
