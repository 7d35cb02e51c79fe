"""Benchmark: the k-nearest-neighbour regression of raw pixels on the outdoor appearance track.

Raw pixels (``baselines/raw_pixels.py``, 4 x 35 x 3 = 420 features per view) are paired with a
3-nearest-neighbour regression over the evaluated rotation windows of every training frame. At
full size that is 5,900 x 24 training views, and each test condition asks for 2,800 x 24 views:
brute force computes every one of those distances. This benchmark reads one world seed's runs
from the render cache (rendering them when missing), computes the raw-pixel features the
protocol computes, and times, on one thread (as on a board, two tasks at a time), the search
of :class:`sfa_gym.localization.KNNRegressor` (``algorithm="bounded"``, the default above 16
features) against scikit-learn's brute force (``algorithm="brute"``, the search before it), the
reference in the same process, on the same ``--queries`` test views of each condition. It
checks that both find the same neighbours (ties aside: scikit-learn breaks them by its
round-off, the bounded search by index) and prints the time of a whole task's searches for both
(the timed share scaled to all test views).

Usage (from the repository root; about 10 minutes on 2 cores)::

    .venv/bin/python -m eval.benchmarks.bench_knn [--cache DIR] [--queries 4000]
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Args:
    world_seed: int = 300
    """a world seed of the outdoor_appearance track"""
    queries: int = 4000
    """test views timed per condition (evenly spread)"""
    cache: Path | None = None
    """the render cache (default: sfa_gym.recording.cache.default_cache_dir())"""
    out: Path = ROOT / "published" / "benchmarks" / "knn.json"


def main(args: Args) -> None:
    from sklearn.neighbors import NearestNeighbors

    from baselines.raw_pixels import RawPixels
    from sfa_gym.features import view_features
    from sfa_gym.files import write_json_atomic
    from sfa_gym.leaderboard.tracks import default_track_folder, load_track
    from sfa_gym.localization.nearest import BoundedNeighbors
    from sfa_gym.protocols import outdoor
    from sfa_gym.recording.cache import RunCache

    track = load_track(default_track_folder() / "outdoor_appearance.json")
    config = track.config(False)
    data = outdoor.load_data(config, args.world_seed, RunCache(args.cache, progress=True))
    method = outdoor.fit_outdoor(RawPixels(), config, data)
    train = view_features(method, data.train_pan, config.rotation, data.windows, "train")
    train = train.reshape(-1, train.shape[2])
    rows, total = [], {"bounded": 0.0, "brute": 0.0}
    with threadpool_limits(1):
        start = time.process_time()
        bounded = BoundedNeighbors(train, 3)
        build = {"bounded": time.process_time() - start}
        start = time.process_time()
        brute = NearestNeighbors(n_neighbors=3, algorithm="brute").fit(train)
        build["brute"] = time.process_time() - start
        for condition, test in data.tests.items():
            views = view_features(method, test.panoramas, config.rotation, data.windows, condition)
            views = views.reshape(-1, views.shape[2])
            picked = views[np.linspace(0, len(views) - 1, args.queries).astype(np.intp)]
            seconds = {}
            start = time.process_time()
            found = bounded.kneighbors(picked)[1]
            seconds["bounded"] = time.process_time() - start
            start = time.process_time()
            reference = brute.kneighbors(picked)[1]
            seconds["brute"] = time.process_time() - start
            same = float(np.mean((np.sort(found, 1) == np.sort(reference, 1)).all(1)))
            scale = len(views) / len(picked)
            for name in total:
                total[name] += seconds[name] * scale
            rows.append(
                {
                    "condition": condition,
                    "test_views": len(views),
                    "cpu_seconds": seconds,
                    "same_neighbours": same,
                    "ratio": seconds["brute"] / seconds["bounded"],
                }
            )
            print(
                f"{condition}: bounded {seconds['bounded']:.2f} s, brute {seconds['brute']:.2f} s "
                f"(ratio {rows[-1]['ratio']:.1f}), same neighbours {same:.4f}"
            )
    for name in total:
        total[name] += build[name]
    result = {
        "benchmark": "bench_knn",
        "command": "python -m eval.benchmarks.bench_knn",
        "world_seed": args.world_seed,
        "training_views": len(train),
        "features": int(train.shape[1]),
        "queries_timed": args.queries,
        "build_cpu_seconds": build,
        "conditions": rows,
        "task_cpu_seconds": total,
        "ratio": total["brute"] / total["bounded"],
    }
    write_json_atomic(args.out, result)
    print(
        f"a whole task's searches: bounded {total['bounded']:.0f} CPU s, brute "
        f"{total['brute']:.0f} CPU s, ratio {result['ratio']:.1f}; wrote {args.out}"
    )


if __name__ == "__main__":
    main(tyro.cli(Args))
