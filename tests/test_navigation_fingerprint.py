"""The same navigation episodes in two fresh processes: a small episode set of the obstacle
track (contacts, where a difference in the physics grows fastest), each process rendering into
its own cache and hashing strings with its own seed, gives the same episode fingerprint."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# the obstacle track's quick settings at a smaller size: 6 x 6 training grid, a 0.5 m field and
# four episodes, scored as the leaderboard scores a task (one BLAS thread)
SCRIPT = """
import dataclasses, json, sys
from threadpoolctl import threadpool_limits
from sfa_gym.leaderboard.tracks import load_track
from sfa_gym.plugins import load_method
from sfa_gym.protocols import navigation
from sfa_gym.recording.cache import RunCache

track = load_track("tracks/nav_obstacles.json")
config = dataclasses.replace(
    track.config(quick=True), train_grid=6, field_spacing=0.5, episodes=4
)
method = load_method("baselines/band_means.py", {})
with threadpool_limits(limits=1):
    found = navigation.score(config, method, track.world_seeds[0], RunCache(sys.argv[1]))
scores = found.task_scores()
print(json.dumps({
    "fingerprint": scores["fingerprint"],
    "score": scores["score"],
    "stops": [[float(v) for v in e["path"][-1]] for e in found.episodes],
}))
"""


def _start(cache: Path, hash_seed: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", SCRIPT, str(cache)],
        cwd=ROOT,  # imports this checkout's sfa_gym
        env={**os.environ, "PYTHONHASHSEED": hash_seed},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _result(process: subprocess.Popen[str]) -> dict:
    out, err = process.communicate(timeout=600)
    assert process.returncode == 0, err[-3000:]
    return json.loads(out.strip().splitlines()[-1])


def test_two_fresh_processes_drive_the_same_episodes(tmp_path):
    # side by side (two cores), each from a cold cache of its own
    processes = [_start(tmp_path / "cache_a", "1"), _start(tmp_path / "cache_b", "2")]
    first, second = (_result(p) for p in processes)
    assert len(first["stops"]) == 4
    assert first["fingerprint"] == second["fingerprint"], (first, second)
    assert first["score"] == second["score"]
    # not only to the fingerprint's micrometre: the same physics, bit for bit
    assert first["stops"] == second["stops"]
