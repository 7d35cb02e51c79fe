"""The camera-equivariance claims of docs/localization.md at full size, through the study that
measures them (``python -m eval.studies.camera_equivariance``, 6 positions, networks trained on the
paper's 30 x 30 grid: about 6-10 minutes on 2 cores).

Marked ``expensive``: run with ``.venv/bin/python -m pytest -m expensive
tests/test_camera_equivariance_claims.py``. It checks what the docs state, not the digits:

- the compass camera (the default) turns by whole columns exactly, at 350 x 40 and 600 x 60,
  while the views that turned with the rover (sfa-gym 0.1) miss the 2-grey-level row target;
- the compass camera's fractional turns are as good as the 8-view, 4x supersampled reference
  (within a grey level on the worst row);
- the slow features of the compass camera, averaged over every column, wobble over headings by
  at most a quarter of what they change over 0.1 m of travel; the rover camera's do not.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.expensive


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("equivariance") / "equivariance.json"
    proc = subprocess.run(
        [sys.executable, "-m", "eval.studies.camera_equivariance", "--json", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=3600,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(out.read_text())


@pytest.mark.parametrize("size", ["350x40", "600x60"])
def test_compass_camera_turns_by_whole_columns_exactly(results, size):
    targets, part = results["targets"], results["pixels"][size]
    whole = [j for j, k in enumerate(part["headings"]) if k == int(k)]
    compass, rover = part["cameras"]["compass"], part["cameras"]["rover"]
    assert all(compass["worst_row"][j] <= targets["worst_row_max"] for j in whole)
    assert all(compass["mean"][j] <= targets["mean_max"] for j in whole)
    assert max(rover["worst_row"][j] for j in whole) > targets["worst_row_max"]


@pytest.mark.parametrize("size", ["350x40", "600x60"])
def test_fractional_turns_are_as_good_as_the_supersampled_reference(results, size):
    part = results["pixels"][size]
    fractional = [j for j, k in enumerate(part["headings"]) if k != int(k)]
    compass, reference = part["cameras"]["compass"], part["cameras"]["reference"]
    for j in fractional:
        assert compass["worst_row"][j] <= reference["worst_row"][j] + 1.0


def test_compass_features_averaged_over_every_column_barely_wobble(results):
    wobble_max = results["targets"]["wobble_max"]
    assert results["wobble"]["compass"]["step_1"]["median"] <= wobble_max
    assert results["wobble"]["rover"]["step_1"]["median"] > wobble_max
