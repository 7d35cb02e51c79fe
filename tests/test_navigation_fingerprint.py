"""The same navigation episodes in two fresh processes: a small episode set of the obstacle
track (contacts, where a difference in the physics grows fastest), each process rendering into
its own cache and hashing strings with its own seed, gives the same episode fingerprint.

And on another CPU: numpy's float64 ``exp``/``power``/``arctan2`` take other kernels where it
dispatches to AVX-512, and OpenBLAS picks its kernels per CPU; the controller's step, the field's
look-up and its table use neither (:mod:`sfa_gym.navigation.portable`), which the test below
checks by switching numpy's AVX-512 targets off and OpenBLAS to its Nehalem kernels in one
process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# a track's quick settings at a smaller size: 6 x 6 training grid, a 0.5 m field and a few
# episodes, scored as the leaderboard scores a task (one BLAS thread)
SCRIPT = """
import dataclasses, json, sys
from threadpoolctl import threadpool_limits
from sfa_gym.leaderboard.tracks import load_track
from sfa_gym.plugins import load_method
from sfa_gym.protocols import navigation
from sfa_gym.recording.cache import RunCache

track = load_track(f"tracks/{sys.argv[2]}.json")
config = dataclasses.replace(
    track.config(quick=True), train_grid=6, field_spacing=0.5, episodes=int(sys.argv[3])
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


def _start(
    cache: Path, hash_seed: str, track: str = "nav_obstacles", episodes: int = 4, **env: str
) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", SCRIPT, str(cache), track, str(episodes)],
        cwd=ROOT,  # imports this checkout's sfa_gym
        env={**os.environ, "PYTHONHASHSEED": hash_seed, **env},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _result(process: subprocess.Popen[str]) -> dict:
    out, err = process.communicate(timeout=600)
    if process.returncode != 0:  # not an AssertionError: the xfail below expects only those
        raise RuntimeError(err[-3000:])
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


def _dispatches_avx512() -> bool:
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
    except ImportError:
        return False
    return "X86_V4" in __cpu_dispatch__ and bool(__cpu_features__.get("X86_V4"))


@pytest.mark.skipif(not _dispatches_avx512(), reason="numpy does not use AVX-512 on this CPU")
def test_another_cpus_kernels_drive_the_same_maze_episodes(tmp_path):
    # ten maze episodes: before the controller's arithmetic was portable, their stops differed
    # (in the tenth decimal here; by 0.17 m in one episode when only numpy's kernels were off)
    other_cpu = {
        "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
        "OPENBLAS_CORETYPE": "Nehalem",
    }
    processes = [
        _start(tmp_path / "cache_a", "1", "nav_maze", 10),
        _start(tmp_path / "cache_b", "1", "nav_maze", 10, **other_cpu),
    ]
    first, second = (_result(p) for p in processes)
    assert len(first["stops"]) == 10
    assert first["fingerprint"] == second["fingerprint"], (first, second)
    assert first["stops"] == second["stops"]
