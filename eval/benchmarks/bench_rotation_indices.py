"""Benchmark: raw pixels' features of the scored rotations, asked for by index (the ``indices``
of its fast path ``transform_rotations``) against every rotation computed and the scored ones
picked (the path before it), in the same process.

The outdoor tracks score 24 of the 120 rotations of a 60 x 600 panorama. Raw pixels shrink each
view to 4 x 35 (600 / 35 is no whole factor, so every view is shrunk on its own,
:mod:`sfa_gym.shrink`): asked for the 24, the method shrinks 24 views instead of 120. Both paths
run :func:`sfa_gym.features.view_features` on the same panoramas (random pixels: the
cost does not depend on them), alternating, and must give the same features.

Usage (from the repository root; about a minute)::

    .venv/bin/python -m eval.benchmarks.bench_rotation_indices [--panoramas 400] [--repeats 3]
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro

from sfa_gym.features import fit_method, view_features
from sfa_gym.files import write_json_atomic
from sfa_gym.plugins import load_method_plugin
from sfa_gym.rotation import Rotation, spread_indices


@dataclass(frozen=True)
class Args:
    panoramas: int = 400
    """60 x 600 panoramas transformed per timing"""
    repeats: int = 3
    """alternating timings of each path"""
    out: Path = Path("published/benchmarks/rotation_indices.json")


def main(args: Args) -> None:
    if min(args.panoramas, args.repeats) < 1:
        raise SystemExit(f"--panoramas and --repeats must be >= 1, got {args}")
    rng = np.random.default_rng(0)
    panoramas = rng.integers(0, 256, (args.panoramas, 60, 600, 3), dtype=np.uint8)
    rotation = Rotation(step=5)
    picked = spread_indices(rotation.n_views(600), 24)
    raw = load_method_plugin("raw_pixels")()
    indexed = fit_method(raw, panoramas[:2], rotation)

    class EveryRotation(type(raw)):  # the same method computing all rotations, then picking
        def transform_rotations(self, panoramas, step, indices=None):
            every = super().transform_rotations(panoramas, step)
            return every if indices is None else every[:, indices]

    every = fit_method(EveryRotation(**raw.get_params()), panoramas[:2], rotation)
    seconds: dict[str, list[float]] = {"rotation indices": [], "every rotation, picked": []}
    found = {}
    for _ in range(args.repeats):
        for name, method in (("rotation indices", indexed), ("every rotation, picked", every)):
            start = time.process_time()
            found[name] = view_features(method, panoramas, rotation, picked, progress=False)
            seconds[name].append(time.process_time() - start)
    if not np.array_equal(*found.values()):
        raise SystemExit("the two paths gave different features")
    reference = statistics.median(seconds["every rotation, picked"])
    rows = {
        name: {
            "cpu_s_per_1000_panoramas": 1e3 * statistics.median(s) / args.panoramas,
            "ratio": statistics.median(s) / reference,
        }
        for name, s in seconds.items()
    }
    for name, row in rows.items():
        print(f"{name:<24} {row['cpu_s_per_1000_panoramas']:7.1f} CPU s / 1000  {row['ratio']:.2f}")
    write_json_atomic(
        args.out,
        {
            "panoramas": args.panoramas,
            "panorama": [60, 600],
            "scored_rotations": len(picked),
            "rotations": rotation.n_views(600),
            "repeats": args.repeats,
            "ratio_to": "every rotation, picked",
            "rows": rows,
        },
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args))
