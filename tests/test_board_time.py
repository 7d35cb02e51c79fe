"""eval/benchmarks/board_time.py: a sweep's time per track from its task files (their format:
sfa_gym.leaderboard.task_files), and the docs' ``board-time`` table of it."""

from __future__ import annotations

import datetime
import json
from pathlib import Path

import pytest

from eval.benchmarks.board_time import board_time
from eval.tables.formatters import board_time_table
from sfa_gym.leaderboard.task_files import write_task_file

START = datetime.datetime(2026, 1, 1, 12, 0, 0, tzinfo=datetime.UTC)


def _task(results: Path, track: str, seed: int, end_s: float, seconds: float, **extra) -> None:
    created = (START + datetime.timedelta(seconds=end_s)).isoformat(timespec="seconds")
    phases = {"render": seconds / 2, "other": seconds / 2} if seconds else {}
    output = {"world_seed": seed, "seconds": seconds, "phases": phases, "scores": {"score": 1.0}}
    identity = {"track": {"name": track}, "world_seed": seed}
    path = results / "tasks" / track / "sfa" / f"{seed}.json"
    write_task_file(path, identity, output, None, {"created": created, **extra})


def test_board_time_spans_tracks_and_counts_covered_tasks(tmp_path):
    # two tasks at a time: track a from 0 to 120 s, track b from 60 to 300 s
    _task(tmp_path, "a", 1, end_s=100, seconds=100)
    _task(tmp_path, "a", 2, end_s=120, seconds=120)
    _task(tmp_path, "b", 1, end_s=300, seconds=240)
    _task(tmp_path, "b", 2, end_s=280, seconds=180)
    _task(tmp_path, "c", 1, end_s=300, seconds=0.0, scored_with="b / sfa / world seed 1")
    out = board_time(tmp_path, "sfa")
    rows = {row["track"]: row for row in out["tracks"]}
    assert [row["track"] for row in out["tracks"]] == ["a", "b", "c"]  # by start
    assert rows["a"]["from_minutes"] == 0.0 and rows["a"]["to_minutes"] == 2.0
    assert rows["b"]["from_minutes"] == 1.0 and rows["b"]["wall_minutes"] == 4.0
    assert rows["b"]["task_seconds"] == 420 and rows["b"]["phases"]["render"] == 210
    assert (
        rows["c"]["covered"] == 1 and rows["c"]["tasks"] == 0 and rows["c"]["from_minutes"] is None
    )
    assert out["wall_minutes"] == 5.0 and out["task_seconds"] == 640
    assert out["cores_busy"] == pytest.approx(640 / 300, abs=0.01)

    table = board_time_table([json.loads(json.dumps(out))], {})
    assert "| `b` | 1.0 | 5.0 | 4.0 | 420 | 210 |  |" in table
    assert "| `c` | - | - | 0.0 | 0 | 0 | 1 |" in table
    assert "| **the whole board, sfa** |  |  | **5.0** | 640 | 320 |  |" in table
    # the renders spread evenly over the machine's cores: the board's floor at this cache
    cpus = out["machine"]["cpus"]
    assert f"| rendering alone, spread over {cpus} cores |  |  | {320 / cpus / 60:.1f} |" in table
    # several methods: a column each
    other = json.loads(json.dumps(out)) | {"method": "pca", "wall_minutes": 2.5}
    other["tracks"] = other["tracks"][:1]
    table = board_time_table([out, other], {})
    assert "| track: wall min | sfa | pca |" in table
    assert "| `a` | 2.0 | 2.0 |" in table and "| `b` | 4.0 | - |" in table
    assert "| `c` | covered | - |" in table
    assert "| **the whole board** | **5.0** | **2.5** |" in table


def test_board_time_needs_finished_tasks_of_the_method(tmp_path):
    _task(tmp_path, "a", 1, end_s=10, seconds=10)
    with pytest.raises(ValueError, match="no finished task of method 'pca'"):
        board_time(tmp_path, "pca")
    with pytest.raises(ValueError, match="board-time: expected a file"):
        board_time_table([{"results": []}], {})
