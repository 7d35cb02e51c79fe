"""Study: how hard is each appearance condition? The change of a panorama at a fixed pose against
its change over 0.3 m.

For each outdoor appearance track and world seed, the test path is recorded once as the drive's
test part (``after``) and once per condition (the track's: 4 h later, overcast, without movers,
another day; and ``--extra`` conditions on no track yet: thick fog, another day's parked
objects), with the same driver and seed; with ``--shadows``, every run casts the sun's
shadows. For every ``--every``-th test frame this compares

- *fixed pose*: the condition's panorama with the ``after`` panorama of the same frame (the
  rover's pose is the same up to the physics' round-off; the table reports the largest
  difference), and
- *0.3 m*: the ``after`` panorama with the ``after`` panorama of the nearest frame in time whose
  position is 0.3 m away (the light and the noise are those of a few seconds later),

as the mean absolute difference of their grey levels (0-255), the second panorama rolled so that
both look the same way (column ``c`` looks at ``yaw + 2 pi c / W``). A condition whose ratio of
the two is above 1 changes a place's image more than moving 0.3 m does. The runs come from the
leaderboard's render cache (rendered when missing). Writes
``published/studies/appearance_change.json``; docs/outdoor.md's table is generated from it.

Usage (from the repository root)::

    .venv/bin/python -m eval.studies.appearance_change --cache ~/.cache/sfa_gym/runs
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tyro
from tqdm.auto import tqdm

from sfa_gym.files import write_json_atomic
from sfa_gym.image_statistics import grey as luma

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Args:
    tracks: tuple[str, ...] = ("outdoor_appearance", "outdoor_appearance_textured")
    """appearance tracks (names in tracks/) whose full-size runs are compared"""
    world_seeds: int = 2
    """the first this many world seeds of each track"""
    every: int = 10
    """compare every n-th test frame"""
    distance: float = 0.3
    """the move the fixed-pose change is compared with, m"""
    extra: tuple[str, ...] = ("fog", "rearranged")
    """conditions compared beyond the track's own (sfa_gym.protocols.outdoor.CONDITIONS)"""
    shadows: bool = False
    """every run (the drive and each condition) with the sun's cast shadows"""
    cache: Path | None = None
    """the render cache (default: sfa_gym.recording.cache.default_cache_dir())"""
    out: Path = ROOT / "published" / "studies" / "appearance_change.json"


def grey(panoramas: np.ndarray) -> np.ndarray:
    """``(N, H, W, 3)`` uint8 -> ``(N, H, W)`` grey levels 0-255 (the image statistics' luma)."""
    return 255.0 * luma(panoramas)


def aligned_change(a: np.ndarray, yaw_a: float, b: np.ndarray, yaw_b: float) -> float:
    """Mean absolute difference of grey panoramas ``a`` and ``b`` (H, W), ``b`` rolled so that
    its columns look where ``a``'s do."""
    width = a.shape[1]
    shift = int(round((yaw_a - yaw_b) / (2 * np.pi) * width))
    return float(np.mean(np.abs(a - np.roll(b, -shift, axis=1))))


def partner(xy: np.ndarray, i: int, distance: float) -> int | None:
    """The frame nearest in time to ``i`` whose position is at least ``distance`` from ``i``'s."""
    far = np.linalg.norm(xy - xy[i], axis=1) >= distance
    later, earlier = np.flatnonzero(far[i:]), np.flatnonzero(far[: i + 1][::-1])
    steps = [s for s in (later[:1] + i, i - earlier[:1]) if len(s)]
    if not steps:
        return None
    return int(min((int(s[0]) for s in steps), key=lambda j: abs(j - i)))


def seed_changes(track: Any, world_seed: int, runs: Any, args: Args) -> dict[str, Any]:
    """The fixed-pose change of every condition and the change over ``distance`` of one world."""
    from sfa_gym.protocols import outdoor

    config = track.config(False)
    extra = tuple(c for c in args.extra if c not in config.conditions)
    config = dataclasses.replace(
        config, conditions=(*config.conditions, *extra), shadows=config.shadows or args.shadows
    )
    got = {
        name: runs.get(request) for name, request in outdoor.requests(config, world_seed).items()
    }
    n = config.train_frames
    frames = np.arange(0, config.test_frames, args.every)
    after = got["drive"]
    after_poses = np.asarray(after.poses[n:])
    after_grey = grey(np.asarray(after.panoramas[n + frames]))
    moves = []
    for f, image in zip(frames, after_grey, strict=True):
        j = partner(after_poses[:, :2], int(f), args.distance)
        if j is not None:
            other = grey(np.asarray(after.panoramas[n + j : n + j + 1]))[0]
            moves.append(aligned_change(image, after_poses[f, 2], other, after_poses[j, 2]))
    out: dict[str, Any] = {
        "world_seed": world_seed,
        "moved": float(np.mean(moves)),
        "conditions": {},
    }
    for condition in config.test_conditions:
        run = got[condition]
        poses = np.asarray(run.poses)
        images = grey(np.asarray(run.panoramas[frames]))
        changes = [
            aligned_change(a, after_poses[f, 2], b, poses[f, 2])
            for f, a, b in zip(frames, after_grey, images, strict=True)
        ]
        offset = np.linalg.norm(poses[frames, :2] - after_poses[frames, :2], axis=1)
        out["conditions"][condition] = {
            "fixed_pose": float(np.mean(changes)),
            "pose_offset_max_m": float(offset.max()),
        }
    return out


def _command(args: Args) -> str:
    """The command line that writes this study's file, with the arguments that change it."""
    words = ["python -m eval.studies.appearance_change"]
    for name in ("tracks", "extra"):
        value = getattr(args, name)
        if value != getattr(Args, name):
            words.append(f"--{name} {' '.join(value)}")
    if args.world_seeds != Args.world_seeds:
        words.append(f"--world-seeds {args.world_seeds}")
    if args.shadows:
        words.append("--shadows")
    return " ".join(words)


def main(args: Args) -> None:
    from sfa_gym.leaderboard.tracks import default_track_folder, load_track
    from sfa_gym.recording.cache import RunCache

    runs = RunCache(args.cache, progress=True)
    results = []
    for name in args.tracks:
        track = load_track(default_track_folder() / f"{name}.json")
        seeds = track.world_seeds[: args.world_seeds]
        per_seed = [
            seed_changes(track, seed, runs, args) for seed in tqdm(seeds, desc=name, unit="world")
        ]
        conditions = list(per_seed[0]["conditions"])
        moved = float(np.mean([s["moved"] for s in per_seed]))
        rows = {}
        for c in conditions:
            fixed = float(np.mean([s["conditions"][c]["fixed_pose"] for s in per_seed]))
            offset = max(s["conditions"][c]["pose_offset_max_m"] for s in per_seed)
            rows[c] = {"fixed_pose": fixed, "ratio": fixed / moved, "pose_offset_max_m": offset}
        results.append(
            {
                "track": name,
                "world_seeds": list(seeds),
                "moved": moved,
                "conditions": rows,
                "per_seed": per_seed,
            }
        )
    write_json_atomic(
        args.out,
        {
            "study": "appearance_change",
            "command": _command(args),
            "shadows": args.shadows,
            "distance_m": args.distance,
            "every": args.every,
            "results": results,
        },
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main(tyro.cli(Args))
