"""Smoke run of the SFA benchmark script (eval/benchmarks/bench_sfa.py) with a tiny budget, our
engine only (MDP needs more training data than a smoke run has to train the upper layers)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_sfa_runs_every_part_and_reports_per_view_figures(tmp_path):
    out = tmp_path / "bench.json"
    argv = ["--frames", "120", "--test-frames", "30", "--locations", "12"]
    argv += ["--rotation-locations", "4", "--skip-mdp", "--no-progress", "--json", str(out)]
    proc = subprocess.run(
        [sys.executable, "-m", "eval.benchmarks.bench_sfa", *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "part 1b: 280 rotated views" in proc.stdout
    results = json.loads(out.read_text())
    ours, rot, paper = results["ours"], results["rotations"], results["paper"]
    assert ours["n_training_views"] == 120 and ours["fit_ms_per_frame"] > 0
    # the same 4 x 70 views, once through the rotation shortcut and once materialised
    assert rot["ours"]["fit_method"] == "rotations-shortcut"
    assert rot["ours_views"]["fit_method"] == "views"
    assert rot["ours"]["n_training_views"] == rot["ours_views"]["n_training_views"] == 280
    assert len(rot["agreement_views"]["training_views"]["abs_corr"]) == 8
    assert paper["n_training_views"] == 12 * 120
    assert "speedup_vs_mdp" not in results["checks"]  # no MDP run, no ratio
    assert set(results["checks"]) == {"inference_ms", "paper_scale_time", "paper_scale_memory"}
