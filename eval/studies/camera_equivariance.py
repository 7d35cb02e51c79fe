"""Study: does the camera turn with the rover, and do the slow features wobble with it?

Backs docs/localization.md ("Rotation equivariance of the camera"); writes
``published/studies/equivariance.json`` and, with ``--png``, ``docs/equivariance.png``.

A real omnidirectional camera that turns in place sees the same image, shifted. Two parts, for
both camera modes (``PanoramaSpec.views``: "compass", the default, and "rover", the camera of
sfa-gym 0.1), in one process:

1. **Pixels.** At random positions of the world, the rover renders a panorama, turns by
   ``2*pi*k/W`` and renders again; the turned panorama is shifted back by ``k`` columns (linear
   interpolation between columns for a fractional ``k``) and compared with the first. Printed per
   heading: the worst row's mean absolute error and the mean over the panorama (grey levels,
   the three channels alike), the maximum over the positions. A fractional shift also
   measures how well a sampled panorama can be interpolated at all; the same figure for a
   reference camera (8 views, 4x supersampling, compass) shows that floor.
2. **Features.** A hierarchical SFA network (the paper's simulator network) is trained for each
   camera mode on the paper's simulator grid (624 positions in Hilbert order, random
   headings). At interior positions (at least 0.6 m from the walls), the rover looks in 16
   random (continuous) headings; the features of a panorama are averaged over its rotated
   views. The wobble is the RMS distance of those features from their mean over the headings,
   in units of the mean distance between the heading-averaged features of the position and of
   positions 0.1 m away (8 directions). Two averages: over the views every 5 columns (the
   protocols' windows) and over every column.

Targets (issue "rotation-equivariant panoramas"): worst row <= 2 grey levels and mean <= 0.5 at
every heading, at 350 x 40 and 600 x 60; wobble <= 1/4 of the change over 0.1 m. The
panorama's cost is measured by ``eval/benchmarks/bench_env.py``.

Usage (from the repository root)::

    .venv/bin/python -m eval.studies.camera_equivariance                   # both parts, ~5 min
    .venv/bin/python -m eval.studies.camera_equivariance --quick           # smoke run
    .venv/bin/python -m eval.studies.camera_equivariance --png docs/equivariance.png
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import tyro
from tqdm import tqdm

from sfa_gym.cli.localize import GridExperiment
from sfa_gym.features import rotation_averaged_features
from sfa_gym.files import write_json_atomic
from sfa_gym.protocols.grid import training_panoramas
from sfa_gym.protocols.settings import SFASettings
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.env import OmniRoverEnv

ROOT = Path(__file__).resolve().parents[2]

MODES = ("rover", "compass")
LABELS = {
    "rover": "views turning with the rover (0.1)",
    "compass": "compass views",
    "reference": "reference: 8 compass views, 4x supersampling",
}
TARGETS = {"worst_row_max": 2.0, "mean_max": 0.5, "wobble_max": 0.25}


def interior_positions(env: OmniRoverEnv, n: int, margin: float, seed: int) -> np.ndarray:
    xmin, xmax, ymin, ymax = env.arena_bounds
    rng = np.random.default_rng(seed)
    return rng.uniform((xmin + margin, ymin + margin), (xmax - margin, ymax - margin), (n, 2))


def render(env: OmniRoverEnv, x: float, y: float, yaw: float) -> np.ndarray:
    return env.reset(options={"pose": (x, y, yaw)})[0]


def shift_back(turned: np.ndarray, k: float) -> np.ndarray:
    """The panorama before a turn by ``k`` columns: ``turned(c - k)``, linear in between."""
    whole = math.floor(k)
    frac = k - whole
    a = np.roll(turned.astype(np.float64), whole, axis=1)
    return a if frac == 0 else (1 - frac) * a + frac * np.roll(a, 1, axis=1)


def row_errors(base: np.ndarray, turned: np.ndarray, k: float) -> np.ndarray:
    """Mean absolute error of each row (grey levels) after shifting ``turned`` back."""
    return np.abs(shift_back(turned, k) - base).mean(axis=(1, 2))


def headings(width: int, quick: bool) -> list[float]:
    """Column shifts: whole ones spread over half a turn (a quarter and half a turn among
    them), then fractional ones."""
    whole = [1, 3, 5, 17, 33, 50, 70, width // 4, width // 2] if not quick else [5, 33, width // 4]
    return [float(k) for k in whole] + ([0.5, 12.25, 33.5, 60.75] if not quick else [12.25])


def pixel_part(spec: PanoramaSpec, n_positions: int, quick: bool) -> dict:
    """Per camera and heading: worst row and mean error, max over positions; row profiles."""
    ks = headings(spec.width, quick)
    cameras = {mode: replace(spec, views=mode) for mode in MODES}
    cameras["reference"] = replace(spec, n_views=8, supersample=4, views="compass")
    out: dict = {"headings": ks, "cameras": {}}
    profile_headings = [j for j, k in enumerate(ks) if k == int(k) and k % (spec.width / 4)]
    for name, cam_spec in cameras.items():
        env = OmniRoverEnv(panorama=cam_spec)
        rng = np.random.default_rng(11)
        poses = interior_positions(env, n_positions, 0.3, seed=11)
        errors = np.zeros((n_positions, len(ks), spec.height))
        for i, (x, y) in enumerate(tqdm(poses, desc=f"{spec.width}x{spec.height} {name}")):
            yaw = float(rng.uniform(-np.pi, np.pi))
            base = render(env, x, y, yaw).astype(np.float64)
            for j, k in enumerate(ks):
                if name == "reference" and k == int(k):
                    continue  # the reference is for the fractional shifts' floor
                turned = render(env, x, y, yaw + 2 * math.pi * k / spec.width)
                errors[i, j] = row_errors(base, turned, k)
        env.close()
        out["cameras"][name] = {
            "worst_row": errors.max(axis=2).max(axis=0).round(3).tolist(),
            "mean": errors.mean(axis=2).max(axis=0).round(3).tolist(),
            # mean row profile over the positions and the whole shifts that are not quarter
            # turns (where the views of a rover camera map onto each other)
            "row_profile": errors[:, profile_headings].mean(axis=(0, 1)).round(3).tolist(),
        }
    return out


def train_model(mode: str, settings: SFASettings, grid: int, n_train: int):
    """The paper's simulator network trained on the grid protocol's training positions."""
    env = OmniRoverEnv(panorama=PanoramaSpec(views=mode))
    config = GridExperiment(
        grid=grid, n_train=n_train, n_test=min(196, grid * grid - n_train), sfa=settings
    )
    panoramas = training_panoramas(env, config)
    model = settings.make_model(*panoramas.shape[1:3]).fit_rotations(panoramas, step=config.step)
    return env, model


def wobble_part(
    settings: SFASettings, grid: int, n_train: int, n_positions: int, n_headings: int
) -> dict:
    out: dict = {}
    for mode in MODES:
        env, model = train_model(mode, settings, grid, n_train)
        rng = np.random.default_rng(5)
        positions = interior_positions(env, n_positions, 0.6, seed=5)
        directions = 2 * math.pi * (np.arange(8) + 0.5) / 8
        rows = {1: [], 5: []}
        for x, y in tqdm(positions, desc=f"wobble ({mode})"):
            here = np.stack(
                [render(env, x, y, h) for h in rng.uniform(-math.pi, math.pi, n_headings)]
            )
            near = [
                np.stack(
                    [
                        render(env, x + 0.1 * math.cos(a), y + 0.1 * math.sin(a), h)
                        for h in rng.uniform(-math.pi, math.pi, 2)
                    ]
                )
                for a in directions
            ]
            for step in rows:
                f = rotation_averaged_features(model, here, step)
                centre = f.mean(axis=0)
                spread = math.sqrt(((f - centre) ** 2).sum(axis=1).mean())
                change = np.mean(
                    [
                        np.linalg.norm(
                            rotation_averaged_features(model, p, step).mean(axis=0) - centre
                        )
                        for p in near
                    ]
                )
                rows[step].append(spread / change)
        env.close()
        out[mode] = {
            f"step_{step}": {
                "median": round(float(np.median(r)), 4),
                "max": round(float(np.max(r)), 4),
                "per_position": np.round(r, 4).tolist(),
            }
            for step, r in rows.items()
        }
    return out


def format_pixels(spec: PanoramaSpec, part: dict) -> str:
    ks = part["headings"]
    lines = [
        f"panorama {spec.width} x {spec.height}: error after turning by k columns and shifting "
        "back (grey levels; worst row / mean; max over positions)",
        "  k        " + "".join(f"{k:>13g}" for k in ks),
    ]
    for name, cam in part["cameras"].items():
        cells = [
            f"{w:6.2f}/{m:5.2f}" if name != "reference" or k != int(k) else f"{'-':>13}"
            for k, w, m in zip(ks, cam["worst_row"], cam["mean"], strict=True)
        ]
        lines.append(f"  {name:9s}" + "".join(f"{c:>13}" for c in cells))
    return "\n".join(lines)


def format_wobble(part: dict) -> str:
    lines = [
        "feature wobble over headings / feature change over 0.1 m (median, max over positions)"
    ]
    for mode, steps in part.items():
        cells = [
            f"views every {s.split('_')[1]} col: {v['median']:.3f} ({v['max']:.3f})"
            for s, v in steps.items()
        ]
        lines.append(f"  {mode:8s} " + "   ".join(cells))
    return "\n".join(lines)


def save_figure(path: Path, pixels: dict[str, dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(pixels), 2, figsize=(10, 3.3 * len(pixels)), squeeze=False)
    for row, (size, part) in enumerate(pixels.items()):
        ks = np.array(part["headings"])
        whole = ks == np.floor(ks)
        ax = axes[row, 0]
        for name, cam in part["cameras"].items():
            if name == "reference":
                continue
            ax.plot(cam["row_profile"], label=LABELS[name])
        ax.set(
            title=f"{size}: error per row (whole-column turns)",
            xlabel="row (0 = top)",
            ylabel="grey levels",
        )
        ax.legend(fontsize=8)
        ax = axes[row, 1]
        for name, cam in part["cameras"].items():
            worst = np.array(cam["worst_row"])
            sel = ~whole if name == "reference" else np.ones_like(whole)
            style = "s" if name == "reference" else "o-"
            ax.plot(np.flatnonzero(sel), worst[sel], style, label=LABELS[name])
        ax.axhline(TARGETS["worst_row_max"], color="grey", ls="--", lw=1)
        ax.set_xticks(range(len(ks)), [f"{k:g}" for k in ks], rotation=60)
        ax.legend(fontsize=8)
        ax.set(
            title=f"{size}: worst row per turn",
            xlabel="turn (columns; a fraction is compared with linear interpolation)",
            ylabel="grey levels",
        )
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)


@dataclass(frozen=True)
class Args:
    quick: bool = False
    """small smoke run (2 positions, a 12 x 12 training grid)"""
    positions: int = 6
    """positions of the pixel part"""
    png: Path | None = None
    """write the figure here (docs/equivariance.png)"""
    json: Path = ROOT / "published" / "studies" / "equivariance.json"
    """write the figures here"""
    features: bool = True
    """run the feature part (``--no-features``: the pixel part alone)"""


def main(args: Args) -> None:
    if args.positions < 1:
        raise SystemExit(f"--positions must be at least 1, got {args.positions}")
    n_positions = 2 if args.quick else args.positions

    pixels = {}
    for spec in (PanoramaSpec.paper_sim(), PanoramaSpec.paper_outdoor()):
        part = pixel_part(spec, n_positions, args.quick)
        pixels[f"{spec.width}x{spec.height}"] = part
        print(format_pixels(spec, part), flush=True)
    results: dict = {"targets": TARGETS, "pixels": pixels}
    if args.features:
        if args.quick:
            settings, grid, n_train, n_pos, n_head = SFASettings(), 12, 100, 2, 4
        else:
            settings, grid, n_train, n_pos, n_head = SFASettings(), 30, 624, 8, 16
        results["wobble"] = wobble_part(settings, grid, n_train, n_pos, n_head)
        print(format_wobble(results["wobble"]))
    args.json.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.json, results)
    if args.png is not None:
        save_figure(args.png, pixels)
        print(f"figure: {args.png}")


if __name__ == "__main__":
    main(tyro.cli(Args))
