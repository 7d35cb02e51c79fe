"""The command line's protocols run their baselines as the leaderboard does: each plug-in file in
a worker process of its own, which cannot find the evaluator's positions to return as features
(in-process it can, and scores an error of almost zero: the test can fail)."""

from __future__ import annotations

import json

import pytest

from sfa_gym.cli import main
from sfa_gym.sandbox import IN_PROCESS

PEEKER = '''
from dataclasses import dataclass
import sys
import numpy as np

@dataclass(frozen=True)
class Args:
    pass

class Method:
    """Band means, unless the evaluator's rendered grid (panoramas and their positions) lies in
    a caller's frame: then each view's position, found by the pixel sum of its panorama (a
    rotation keeps it)."""
    name = "peeker"
    def fit(self, views, sequence_ids=None):
        self.input_shape_ = views.shape[1:]
        return self
    def transform(self, views):
        wanted = views.reshape(len(views), -1).sum(axis=1, dtype=np.int64)
        frame = sys._getframe()
        while frame is not None:
            for value in list(frame.f_locals.values()):
                positions = getattr(value, "positions", None)
                panoramas = getattr(value, "panoramas", None)
                if isinstance(positions, np.ndarray) and panoramas is not None:
                    sums = np.asarray(panoramas).reshape(len(positions), -1).sum(axis=1)
                    where = {int(s): i for i, s in enumerate(sums)}
                    if all(int(w) in where for w in wanted):
                        return positions[[where[int(w)] for w in wanted]].astype(np.float64)
            frame = frame.f_back
        return views.reshape(len(views), 4, -1).mean(axis=2).astype(np.float64)

METHOD = Method
'''

ARGV = ["localize", "--grid", "10", "--n-train", "60", "--n-test", "30", "--node-dim", "10"]
ARGV += ["--n-splits", "5", "--quiet"]


def _peeker_error(tmp_path, name):
    folder = tmp_path / f"plugins_{name}"
    folder.mkdir()
    (folder / "peeker.py").write_text(PEEKER)
    out = tmp_path / name
    assert main([*ARGV, "--out", str(out), "--baselines", str(folder)]) == 0
    results = json.loads((out / "results.json").read_text())
    return max(results["methods"]["peeker"]["linear"]["train_test"]["mae_percent"])


@pytest.mark.parametrize("where", ["worker", "in_process"])
def test_a_baseline_cannot_read_the_positions_of_the_evaluator(tmp_path, monkeypatch, where):
    if where == "in_process":
        monkeypatch.setenv(IN_PROCESS, "1")
        assert _peeker_error(tmp_path, where) < 0.5  # it found them
    else:
        assert _peeker_error(tmp_path, where) > 5.0  # band means of 4 rows, no positions
