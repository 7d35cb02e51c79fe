"""Peak memory: a process's high-water mark and its reset, a worker tree's peak, and the peaks
each leaderboard task records for the evaluator and its plug-in workers."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest
from test_leaderboard import TINY, _write_track, band_means_fitting

from sfa_gym import memory
from sfa_gym.leaderboard.evaluate import Task, plugins_isolated, run_task

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="peak memory is read from Linux's /proc"
)


def test_own_peak_follows_an_allocation_and_starts_afresh():
    memory.reset_own_peak()
    before = memory.own_peak_mb()
    block = np.ones(300 * 2**20 // 8)  # 300 MiB, touched
    peak = memory.own_peak_mb()
    del block
    assert peak - before > 290
    memory.reset_own_peak()
    assert memory.own_peak_mb() < peak - 290  # the freed block no longer counts


def test_a_tree_peak_sums_a_process_and_its_children():
    grow = "import time; b = bytearray(200 * 2**20); b[::4096] = b'x' * len(b[::4096]); "
    code = (
        "import subprocess, sys; "
        f"child = subprocess.Popen([sys.executable, '-c', {grow + 'time.sleep(60)'!r}]); "
        f"{grow}print('ready', flush=True); time.sleep(60)"
    )
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout.readline().strip() == "ready"
        deadline = time.monotonic() + 30
        while (peak := memory.tree_peak_mb(parent.pid)) < 400 and time.monotonic() < deadline:
            time.sleep(0.2)  # the child may still be allocating
        assert 400 < peak < 600  # two processes of 200 MiB each and their interpreters
    finally:
        subprocess.run(["pkill", "-P", str(parent.pid)], check=False)
        parent.kill()
        parent.wait()
    assert memory.tree_peak_mb(parent.pid) is None  # gone: nothing to read


def test_a_task_records_the_peaks_of_the_evaluator_and_the_plugin(tmp_path):
    track = str(_write_track(tmp_path / "tracks", TINY))
    # a block of 400 MiB, touched, kept by the fitted method
    hog = band_means_fitting(tmp_path / "hog.py", "self.block_ = np.ones(400 * 2**20 // 8)")
    cache = str(tmp_path / "cache")
    plain = band_means_fitting(tmp_path / "plain.py", "pass")  # from outside too: a worker
    plain = run_task(Task(track, str(plain), {}, 100, cache_dir=cache))["peak_rss_mb"]
    heavy = run_task(Task(track, str(hog), {}, 100, cache_dir=cache))["peak_rss_mb"]
    assert plain["evaluator"] > 50 and heavy["evaluator"] > 50
    if not plugins_isolated():
        assert plain["plugins"] is None and heavy["evaluator"] - plain["evaluator"] > 350
        return
    assert heavy["plugins"] - plain["plugins"] > 350  # the plug-in's block, in its worker
    assert abs(heavy["evaluator"] - plain["evaluator"]) < 200  # and not in the evaluator
