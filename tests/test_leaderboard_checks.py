"""Comparable results: every result records the locked packages' versions, navigation tasks their
episode fingerprints; ``leaderboard table`` marks results off the lock or off the reference's
episodes."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from sfa_gym.cli.main import main
from sfa_gym.leaderboard.checks import FINGERPRINT_MARK, VERSIONS_MARK, check_board, fingerprints
from sfa_gym.leaderboard.results import (
    FORMAT,
    SCHEMA_VERSION,
    load_results,
    make_result,
    summarize,
)
from sfa_gym.leaderboard.table import load_board, markdown_table
from sfa_gym.leaderboard.tracks import load_track
from sfa_gym.lock import installed_versions, read_lock
from sfa_gym.protocols.navigation import FINGERPRINT_DECIMALS, episode_fingerprint

ROOT = Path(__file__).resolve().parents[1]
NAV_OPEN = load_track(ROOT / "tracks" / "nav_open.json")  # the table compares with its version


def _episode(seed: int, stop: tuple[float, float], steps: int = 100) -> dict:
    return {
        "seed": seed,
        "start": [0.5, -1.25, 0.3],
        "goal": [2.0, 1.0, -1.5],
        "path": np.array([[0.5, -1.25], [1.0, -0.5], stop]),
        "steps": steps,
    }


def test_the_fingerprint_follows_the_poses_to_a_micrometre():
    episodes = [_episode(1000, (1.9, 0.9)), _episode(1001, (-0.0000001, 2.0))]
    reference = episode_fingerprint(episodes)
    assert len(reference) == 16 and int(reference, 16) >= 0
    # round-off far below the rounding, and the sign of a rounded zero, change nothing
    nudged = [_episode(1000, (1.9 + 1e-12, 0.9)), _episode(1001, (1e-7, 2.0 - 1e-13))]
    assert episode_fingerprint(nudged) == reference
    assert 10.0**-FINGERPRINT_DECIMALS == 1e-6
    # a stop 10 um away, another step count, start, goal or seed: another fingerprint
    moved = [_episode(1000, (1.9 + 1e-5, 0.9)), episodes[1]]
    longer = [_episode(1000, (1.9, 0.9), steps=101), episodes[1]]
    other_goal = [{**episodes[0], "goal": [2.0, 1.0, -1.4]}, episodes[1]]
    other_seed = [{**episodes[0], "seed": 7}, episodes[1]]
    found = {episode_fingerprint(e) for e in (moved, longer, other_goal, other_seed)}
    assert len(found) == 4 and reference not in found
    assert episode_fingerprint(episodes[::-1]) != reference


def _nav_result(label: str, prints: dict[int, str], versions: dict | None) -> dict:
    """A navigation result (the fields the table reads), with fingerprints per seed."""
    return {
        "track": "nav_open",
        "track_version": NAV_OPEN.track_version,
        "quick": True,
        "size_params": json.loads(json.dumps(NAV_OPEN.sized(True)[1])),
        "method": label,
        "score": summarize([0.5] * len(prints), higher_is_better=True),
        "per_world_seed": {str(s): 0.5 for s in prints},
        "fingerprints": {str(s): f for s, f in prints.items()},
        "isolation": ["bwrap"],
        "versions": versions,
    }


def _file(*results: dict, **fields: object) -> str:
    return json.dumps(
        {"format": FORMAT, "schema_version": SCHEMA_VERSION, **fields, "results": results}
    )


def _write(folder: Path, result: dict) -> None:
    path = folder / "nav_open" / f"{result['method']}.quick.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(_file(result))


def test_results_off_the_lock_or_off_the_reference_episodes_are_marked(tmp_path):
    lock = read_lock()
    off_lock = {**lock, "numpy": "1.0.0"}
    reference = tmp_path / "reference"
    reference.mkdir()
    gathered = [
        _nav_result(label, {100: "aaaa", 101: "bbbb"}, lock)
        | {"cpu_numerics": {"simd": ["X86_V3", "X86_V4"], "blas": []}}
        for label in ("band_means", "pca", "sfa")
    ]
    (reference / "quick.json").write_text(_file(*gathered, description=""))
    yours = tmp_path / "yours"
    _write(yours, _nav_result("band_means", {100: "aaaa", 101: "bbbb"}, lock))  # the same
    pca = _nav_result("pca", {100: "aaaa", 101: "cccc"}, off_lock)  # both differ
    pca["cpu_numerics"] = {"simd": ["X86_V3"], "blas": []}
    _write(yours, pca)
    _write(yours, _nav_result("sfa", {100: "aaaa", 101: "bbbb"}, None))  # written before
    board = load_board(yours, reference)
    marks = check_board(board, lock)
    column = "nav_open (quick)"
    assert marks.versions == {(column, ("pca", "yours")): {"numpy": ("1.0.0", lock["numpy"])}}
    assert marks.fingerprints == {(column, ("pca", "yours")): [101]}
    assert marks.unrecorded == [(column, ("sfa", "yours"))]
    table = markdown_table(board, marks)
    assert f"| pca | yours | 0.50 (n=2) {VERSIONS_MARK}{FINGERPRINT_MARK} |" in table
    assert (
        "| band_means | yours | 0.50 (n=2) |" in table and "| sfa | yours | 0.50 (n=2) |" in table
    )
    assert "| pca | reference | 0.50 (n=2) |" in table
    assert any(line.startswith(VERSIONS_MARK) for line in table.splitlines())
    assert any(line.startswith(FINGERPRINT_MARK) for line in table.splitlines())
    warnings = "\n".join(marks.warnings())
    assert f"numpy 1.0.0 (lock {lock['numpy']})" in warnings
    assert "world seeds [101]" in warnings and "1 result(s) record no package versions" in warnings
    assert "a CPU that rounds differently: {'simd': ['X86_V3']" in warnings
    # another track version is another experiment: its episodes are not compared
    other = _nav_result("band_means", {100: "zzzz"}, lock)
    other["track_version"] = 3
    _write(yours, other)
    assert check_board(load_board(yours, reference), lock).fingerprints.keys() == {
        (column, ("pca", "yours"))
    }


def test_a_result_records_versions_fingerprints_and_spl(tmp_path):
    track = load_track(ROOT / "tracks" / "nav_open.json")
    scores = [
        {"score": 0.5, "fingerprint": f, "spl": spl} for f, spl in (("aaaa", 0.5), ("bbbb", 0.25))
    ]
    result = make_result(
        track=track,
        quick=True,
        method={"label": "band_means"},
        tasks=[
            {"world_seed": 100 + i, "scores": s, "isolation": "bwrap"} for i, s in enumerate(scores)
        ],
        higher_is_better=True,
        backend="local",
    )
    versions = result["versions"]
    assert versions == installed_versions() and set(versions) == set(read_lock())
    numerics = result["cpu_numerics"]
    assert set(numerics) == {"simd", "blas"} and numerics["blas"]  # numpy's OpenBLAS at least
    assert result["fingerprints"] == {"100": "aaaa", "101": "bbbb"}
    assert result["spl"] == {"mean": 0.375, "per_world_seed": {"100": 0.5, "101": 0.25}}
    (tmp_path / "quick.json").write_text(_file(result, description=""))
    (read,) = load_results(tmp_path)
    assert fingerprints(read) == {100: "aaaa", 101: "bbbb"} and read["versions"] == versions
    assert read["per_world_seed"] == {"100": 0.5, "101": 0.5} and read["isolation"] == ["bwrap"]
    json.dumps(result, allow_nan=False)


def test_the_table_command_names_results_off_the_lock_on_stderr(tmp_path, capsys):
    lock = read_lock()
    mine = _nav_result("my_method", {100: "aaaa"}, {**lock, "mujoco": "3.2.0"})
    _write(tmp_path, mine)
    assert main(["leaderboard", "table", "--markdown", "--results", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    row = next(line for line in out.splitlines() if line.startswith("| my_method | yours |"))
    assert f"| 0.50 (n=1) {VERSIONS_MARK} |" in row
    assert f"mujoco 3.2.0 (lock {lock['mujoco']})" in err
    # on the lock: no mark, no line about it
    _write(tmp_path, copy.deepcopy(mine) | {"versions": lock})
    assert main(["leaderboard", "table", "--markdown", "--results", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    row = next(line for line in out.splitlines() if line.startswith("| my_method | yours |"))
    assert "| 0.50 (n=1) |" in row and VERSIONS_MARK not in row and "my_method (yours)" not in err


@pytest.mark.parametrize("bad", ["numpy>=2", "numpy == 2", "-e ."])
def test_the_lock_takes_only_pins(tmp_path, bad):
    path = tmp_path / "constraints.txt"
    path.write_text(f"{bad}\n")
    with pytest.raises(ValueError, match="is not a pin"):
        read_lock(path)
