"""Study: how much of the distance to natural-image statistics is the sparseness of the outdoor
world's surroundings? The textured outdoor world with the counts of its items (trees, bushes,
lamp posts, fence runs, parked cars) multiplied by ``--densities``, measured as
``eval/studies/image_statistics.py`` measures (the slope ``alpha`` of the grey panoramas'
radially averaged amplitude spectrum, natural scenes about 1.0, and the median RMS contrast of
8 x 8 patches; the cylindrical 60 x 600 camera without the sensor, ``--panoramas`` panoramas at
``env.reset(seed=i)``, also rendered at 4x the rows and columns for the world's own slope) on
each of ``--world-seeds``, and the env step's cost against the shipped density in the same
process. The shipped tracks keep the shipped density: this measures a lever, it changes no
world. Writes ``published/studies/item_density.json`` and ``docs/item_density.png`` (the same
place at the shipped and the largest density).

Usage (from the repository root; about five minutes on 2 cores)::

    .venv/bin/python -m eval.studies.item_density
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro
from tqdm.auto import tqdm

from eval.studies.image_statistics import NATURAL, SHARP, _panoramas
from sfa_gym.files import write_json_atomic
from sfa_gym.image_statistics import local_contrast, spectrum_slope
from sfa_gym.intervals import mean_entry

ROOT = Path(__file__).resolve().parents[2]
ITEMS = ("trees", "bushes", "lamp_posts", "fences", "cars")
"""The outdoor spec's item kinds whose counts are multiplied."""
ENV_ID = "sfa_gym/OmniRoverOutdoorTextured-v0"
CAMERA = {"camera": "cylindrical", "mirror": None, "sensor": False}
STEPS = 30
"""env steps timed per world and density (a slow turn in place)"""


@dataclass
class Args:
    densities: tuple[float, ...] = (1.0, 2.0, 3.0, 5.0)
    """factors on the counts of every item kind (1: the shipped world)"""
    world_seeds: tuple[int, ...] = (0, 1, 2, 3, 4, 5, 6, 7)
    """outdoor worlds measured at each density"""
    panoramas: int = 12
    """panoramas per world and density"""
    json: Path = ROOT / "published" / "studies" / "item_density.json"
    """where to write the figures"""
    png: Path = ROOT / "docs" / "item_density.png"
    """where to draw the first world at the shipped and the largest density"""


def dense_spec(factor: float) -> Any:
    """The outdoor world spec with every item count of :data:`ITEMS` times ``factor``."""
    from sfa_gym.sim.worlds.spec import load_world_spec

    spec = load_world_spec("paper_outdoor")
    outdoor = spec.outdoor
    changed = {
        kind: dataclasses.replace(
            getattr(outdoor, kind), count=round(getattr(outdoor, kind).count * factor)
        )
        for kind in ITEMS
    }
    return dataclasses.replace(spec, outdoor=dataclasses.replace(outdoor, **changed))


def _world(factor: float, seed: int, n: int) -> dict[str, Any]:
    """One world at one density: its panoramas, the world's own slope and the step's cost."""
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the ids)

    kwargs = {**CAMERA, "world": dense_spec(factor), "world_seed": seed}
    env = gym.make(ENV_ID, **kwargs)
    try:
        images = np.stack([env.reset(seed=i)[0] for i in range(n)])
        started = time.perf_counter()
        for _ in range(STEPS):
            env.step(np.array([0.0, 0.3], dtype=np.float32))
        step_ms = 1000 * (time.perf_counter() - started) / STEPS
    finally:
        env.close()
    fine = _panoramas(ENV_ID, kwargs, n, SHARP)
    spectrum = spectrum_slope(images)
    return {
        "images": images,
        "alpha": spectrum.alpha,
        "alpha_sharp": spectrum_slope(fine, f_high=spectrum.f_high / SHARP).alpha,
        "contrast_median": float(np.median(local_contrast(images))),
        "step_ms": step_ms,
    }


def measure(args: Args) -> tuple[dict[str, Any], dict[float, np.ndarray]]:
    """Per density the mean over the worlds (with 95 % intervals) and the first world's
    panoramas."""
    rows, first = {}, {}
    cases = [(f, s) for f in args.densities for s in args.world_seeds]
    found: dict[float, list[dict[str, Any]]] = {f: [] for f in args.densities}
    for factor, seed in tqdm(cases, desc="worlds"):
        found[factor].append(_world(factor, seed, args.panoramas))
    base_ms = np.array([w["step_ms"] for w in found[args.densities[0]]])
    for factor, worlds in found.items():
        first[factor] = worlds[0]["images"]
        step_ms = np.array([w["step_ms"] for w in worlds])
        rows[f"{factor:g}"] = {
            "alpha": mean_entry([w["alpha"] for w in worlds], low=-np.inf, digits=3),
            "alpha_sharp": mean_entry([w["alpha_sharp"] for w in worlds], low=-np.inf, digits=3),
            "contrast_median": round(float(np.mean([w["contrast_median"] for w in worlds])), 4),
            "step_ms": round(float(step_ms.mean()), 1),
            # the same worlds' steps at the first density, timed in this process
            "step_ratio": round(float(np.mean(step_ms / base_ms)), 2),
        }
        print(f"items x{factor:g}: alpha {rows[f'{factor:g}']['alpha']['mean']:.3f}, world's "
              f"own {rows[f'{factor:g}']['alpha_sharp']['mean']:.3f}")  # fmt: skip
    return rows, first


def draw(first: dict[float, np.ndarray], path: Path) -> None:
    """The first panorama of the first world at the first and the last density, stacked."""
    import cv2

    factors = [min(first), max(first)]
    strip = np.concatenate([first[f][0] for f in factors], axis=0)
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.ascontiguousarray(strip[..., ::-1]))


def main(args: Args) -> int:
    if args.densities[0] != 1.0:
        raise ValueError(f"densities must start with 1 (the shipped world), got {args.densities}")
    rows, first = measure(args)
    write_json_atomic(
        args.json,
        {
            "study": "item_density",
            "world": "paper_outdoor, textured",
            "items": list(ITEMS),
            "world_seeds": list(args.world_seeds),
            "panoramas_per_world": args.panoramas,
            "sharp_scale": SHARP,
            "natural_alpha_band": list(NATURAL),
            "rows": rows,
        },
    )
    draw(first, args.png)
    print(f"wrote {args.json} and {args.png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(tyro.cli(Args)))
