"""The release-drift study's pieces: the release's camera through the render cache, the
release's results read as written, the summary over worlds (the runs themselves are the study's:
``python -m eval.studies.release_drift``)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from eval.studies.release_drift import ReleaseCamera, release_world, summarise
from sfa_gym.recording.cache import RunCache, RunRequest
from sfa_gym.recording.drivers import GridPositions
from sfa_gym.sim.camera import PanoramaSpec
from sfa_gym.sim.env import OmniRoverEnv


def test_the_release_camera_renders_views_that_turn_with_the_rover(tmp_path):
    runs = RunCache(tmp_path)
    request = RunRequest("paper_sim", 3, (12, 48), GridPositions(n=2, seed=1), seed=1)
    today = runs.get(request)
    release = ReleaseCamera(runs).get(request)
    assert len(list(tmp_path.glob("*.run"))) == 2  # a key of its own, not today's entry
    np.testing.assert_array_equal(release.positions, today.positions)
    assert not np.array_equal(release.panoramas[:], today.panoramas[:])
    # the release's camera is PanoramaSpec(views="rover") at the same size and pose
    spec = PanoramaSpec(width=48, height=12, views="rover")
    env = OmniRoverEnv("paper_sim", world_seed=3, panorama=spec)
    try:
        pose = tuple(release.poses[0])
        obs, _ = env.reset(options={"pose": pose})
    finally:
        env.close()
    np.testing.assert_array_equal(obs, release.panoramas[0])


def _results(sfa_map, fft_map):
    def regressions(value):
        part = {"mae_percent": value}
        return {r: {"visited": part, "excluded": part} for r in ("map", "linear")}

    return {
        "methods": {
            "hierarchical_sfa": regressions(sfa_map),
            "fft_magnitude": regressions(fft_map),
        }
    }


def test_the_release_results_are_read_as_written_and_summarised(tmp_path):
    worlds = []
    for seed, (sfa, fft) in enumerate([([2.0, 3.0], [1, 1]), ([3.0, 3.0], [1, 2])]):
        folder = tmp_path / f"old-{seed}"
        folder.mkdir()
        (folder / "results.json").write_text(json.dumps(_results(sfa, fft)))
        worlds.append(release_world(folder))
    assert worlds[0]["sfa"]["map"]["visited"] == [2.0, 3.0]
    assert worlds[1]["fft_magnitude"]["linear"]["excluded"] == [1, 2]
    found = summarise(worlds)
    assert found["sfa"]["map"]["visited"] == [
        {"mean": 2.5, "interval": None},  # two worlds: no interval
        {"mean": 3.0, "interval": None},
    ]
    three = summarise([*worlds, worlds[0]])["fft_magnitude"]["map"]["excluded"]
    assert three[0] == {"mean": 1.0, "interval": [1.0, 1.0]}
    assert three[1]["interval"] == pytest.approx([0.0, 2.7675], abs=1e-4)


def test_the_table_shows_each_code_camera_and_regression_from_the_file():
    from eval.tables.study_formatters import release_drift_table

    def entries(x, y):
        return [{"mean": x, "interval": [x - 1, x + 1]}, {"mean": y, "interval": None}]

    def method(columns):
        return {c: {"visited": entries(1.0, 2.0), "excluded": entries(5.0, 6.0)} for c in columns}

    today = {"sfa": method(("map", "map_plain", "linear"))}
    today["fft_magnitude"] = today["sfa"]
    release = {"sfa": method(("map", "linear")), "fft_magnitude": method(("map", "linear"))}
    data = {"rows": {"compass": today, "release": release}}
    lines = release_drift_table([data], {}).splitlines()
    assert len(lines) == 2 + 2 + 3  # the release's two regressions, today's three
    assert lines[2] == (
        "| release (`60d3351`) | turn with the rover | map decoder, no penalty "
        "| 1.00 [0.00, 2.00] | 2.00 | 1.00 [0.00, 2.00] | 2.00 |"
    )
    assert lines[4].startswith("| today | compass directions | map decoder, penalty chosen |")
    excluded = release_drift_table([data], {"part": "excluded"}).splitlines()
    assert excluded[2].endswith("| 5.00 [4.00, 6.00] | 6.00 | 5.00 [4.00, 6.00] | 6.00 |")
    with pytest.raises(ValueError, match="part must be 'visited' or 'excluded', got 'all'"):
        release_drift_table([data], {"part": "all"})


def test_the_release_is_compared_on_the_env_s_own_world_only(tmp_path):
    from eval.studies.release_drift import Args, main

    with pytest.raises(SystemExit, match="--release compares the env's own world"):
        main(Args(world="paper_sim_maze", release=tmp_path, json=tmp_path / "x.json"))
    assert not (tmp_path / "x.json").exists()
