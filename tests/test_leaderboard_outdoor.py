"""The outdoor tracks: the shipped files load and share their drive, bad outdoor parameters are
refused naming the value, the render cache keys outdoor runs by every env kwarg that changes
their pixels (and by nothing else), and a tiny outdoor track scores band_means end to end with
the result file's schema, rendering the drive once for both tracks and scoring the paper track
with the appearance track's task, exactly as on its own."""

from __future__ import annotations

import copy
import dataclasses
import json
import math
from pathlib import Path

import pytest

from sfa_gym.leaderboard.tracks import TrackError, list_tracks, track_from_dict
from sfa_gym.protocols.outdoor import ENV_ID, requests
from sfa_gym.recording.cache import RunCache, RunRequest
from sfa_gym.recording.outdoor_path import OutdoorPathDriver
from sfa_gym.sim.camera import MirrorSpec
from sfa_gym.sim.worlds import load_world_spec

ROOT = Path(__file__).resolve().parents[1]
BAND_MEANS = ROOT / "baselines" / "band_means.py"

# short versions of the paper's paths (lanes 2 m apart, a frame every 1.6 s: the fewest frames
# the planner accepts for them), 16 x 160 pixels
TINY_PARAMS = {
    "panorama": [16, 160],
    "train_frames": 133,
    "test_frames": 125,
    "frame_dt": 1.6,
    "spacing": 2.0,
    "test_spacing": 2.0,
    "start_hour": 10.0,
    "later_hours": 4.0,
    "conditions": ["after"],
    "step": 5,
    "eval_rotations": 4,
    "fit_every": 2,
}
TINY = {
    "schema_version": 1,
    "name": "outdoor_tiny",
    "track_version": 1,
    "kind": "localization",
    "evaluation": "outdoor",
    "description": "test track",
    "world": "paper_outdoor",
    "world_seeds": [300],
    "seed": 7001,
    "params": TINY_PARAMS,
    "quick": {"world_seeds": 1},
}


def _tiny(name: str = "outdoor_tiny", **params) -> dict:
    data = copy.deepcopy(TINY)
    data["name"] = name
    data["params"].update(params)
    return data


# ----------------------------------------------------------------------------- tracks


def test_shipped_outdoor_tracks_load_and_share_one_drive_per_world_seed():
    tracks = {t.name: t for t in list_tracks(ROOT / "tracks")}
    paper, appearance = tracks["outdoor_paper"], tracks["outdoor_appearance"]
    assert paper.evaluation == appearance.evaluation == "outdoor"
    assert paper.params["conditions"] == ["after"]
    assert appearance.params["conditions"] == ["later", "overcast", "no_movers", "other_day"]
    assert paper.params["train_frames"] == 5900 and paper.params["test_frames"] == 2800
    assert min(paper.world_seeds) >= 10  # outdoor world seeds 0..9 are development seeds
    for quick in (False, True):
        seeds, _ = paper.sized(quick)
        assert appearance.sized(quick)[0] == seeds
        for seed in seeds:
            mine = requests(paper.config(quick), seed)
            theirs = requests(appearance.config(quick), seed)
            assert list(mine) == ["drive"]
            assert list(theirs) == ["drive", "later", "overcast", "no_movers", "other_day"]
            # the appearance track scores on the very render of the paper's track
            assert mine["drive"].key() == theirs["drive"].key()
            assert len({r.key() for r in theirs.values()}) == 5


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["params"].update(conditions=["after", "sunset"]), "'sunset'"),
        (lambda d: d["params"].update(conditions=[]), "conditions must be a non-empty tuple"),
        (lambda d: d["params"].update(conditions=["later", "later"]), "repeats a condition"),
        (lambda d: d["params"].update(frame_dt=0), "params: frame_dt must be a positive"),
        (lambda d: d["params"].update(panorama=[16, 161]), "161"),
        (lambda d: d["params"].update(hours=3), "unknown field 'params.hours'"),
        (lambda d: d["quick"].update(params={"train_frames": 5}), "quick.params: train_frames"),
        (lambda d: d.update(world="paper_sim"), "renders in sfa_gym/OmniRoverOutdoor-v0"),
        (lambda d: d.update(world_seeds=[300, 9]), "world_seeds 9 is a development seed"),
    ],
)
def test_bad_outdoor_track_is_refused_naming_the_value(change, message):
    data = _tiny()
    change(data)
    with pytest.raises(TrackError, match=message):
        track_from_dict(data, "outdoor_tiny.json")


# ------------------------------------------------------------------------------ cache


def _outdoor_request(driver=None, **env_kwargs) -> RunRequest:
    kwargs = {"dynamics": {"start_hour": 10.0}, "control_dt": 0.8, **env_kwargs}
    return RunRequest(
        world="paper_outdoor",
        world_seed=300,
        panorama=(16, 160),
        driver=driver or OutdoorPathDriver("both", train_frames=120, test_frames=60),
        seed=7001,
        env_id=ENV_ID,
        env_kwargs=kwargs,
    )


def test_outdoor_cache_key_changes_with_every_env_kwarg_and_nothing_else():
    declared = load_world_spec("paper_outdoor").dynamics
    base = _outdoor_request()
    changes = {
        "camera": {"camera": "mirror_circular"},
        "mirror": {
            "mirror": dataclasses.replace(
                MirrorSpec.paper_outdoor(), unwarp_centre_offset=(0.0, 0.0)
            )
        },
        "rover": {"rover": "default"},
        "dynamics": {"dynamics": dataclasses.replace(declared, overcast=1.0)},
        "dynamics off": {"dynamics": False},
        "movers": {"dynamics": {"start_hour": 10.0, "movers": False}},
        "start_hour": {"dynamics": {"start_hour": 14.0}},
        "sensor": {"sensor": False},
        "control period": {"control_dt": 0.5},
    }
    keys = {"base": base.key()}
    for what, change in changes.items():
        keys[what] = _outdoor_request(**change).key()
    assert len(set(keys.values())) == len(keys), keys
    # the driver and the frames are part of the key too
    other_path = OutdoorPathDriver("both", train_frames=120, test_frames=60, spacing=1.0)
    assert _outdoor_request(driver=other_path).key() != base.key()
    assert dataclasses.replace(base, n_steps=50).key() != base.key()

    # not otherwise: the registered defaults passed explicitly and the kwargs in another order
    # name the same pixels
    same = _outdoor_request(camera="mirror", mirror="paper_outdoor", rover="outdoor", sensor=True)
    assert same.key() == base.key()
    reordered = dataclasses.replace(base, env_kwargs=dict(reversed(list(base.env_kwargs.items()))))
    assert reordered.key() == base.key()
    content = base.key_content()
    assert content["env_kwargs"] == {"control_dt": 0.8, "dynamics": {"start_hour": 10.0}}


def test_runs_without_env_kwargs_keep_their_keys():
    from sfa_gym.recording.drivers import GridPositions

    plain = RunRequest("paper_sim", 100, (8, 24), GridPositions(n=2, seed=7001), seed=7001)
    assert "env_kwargs" not in plain.key_content()
    # a default passed explicitly is the run without it
    explicit = dataclasses.replace(plain, env_kwargs={"v_max": 0.4, "camera": "cylindrical"})
    assert explicit.key() == plain.key()
    assert dataclasses.replace(plain, env_kwargs={"v_max": 0.3}).key() != plain.key()


@pytest.mark.parametrize(
    ("env_kwargs", "error", "message"),
    [
        ({"colour": "red"}, ValueError, "env kwarg 'colour' is not a keyword argument"),
        ({"world_seed": 3}, ValueError, "'world_seed' is a field of the RunRequest"),
        ({"dynamics": {"start_hour": math.nan}}, TypeError, "dynamics.start_hour = nan"),
        ({"sensor": object()}, TypeError, "env kwarg sensor = <object"),
    ],
)
def test_bad_env_kwargs_are_named(env_kwargs, error, message):
    with pytest.raises(error, match=message):
        _outdoor_request(**env_kwargs).key()


# ------------------------------------------------------------------------- evaluation


def test_tiny_outdoor_tracks_score_band_means_and_share_the_drive(tmp_path):
    from sfa_gym.leaderboard.results import load_results
    from sfa_gym.leaderboard.sweep import run_sweep
    from sfa_gym.leaderboard.table import write_table
    from sfa_gym.leaderboard.tracks import load_track

    folder = tmp_path / "tracks"
    folder.mkdir()
    for data in (_tiny(), _tiny("outdoor_tiny_later", conditions=["later"])):
        (folder / f"{data['name']}.json").write_text(json.dumps(data))
    tracks = [
        load_track(folder / "outdoor_tiny.json"),
        load_track(folder / "outdoor_tiny_later.json"),
    ]
    cache = tmp_path / "cache"
    written = run_sweep(
        tracks, [(BAND_MEANS, {})], tmp_path / "results", cache_dir=cache, verbose=False
    )
    # the drive once for both tracks, plus the "later" test run
    assert len(RunCache(cache).renders()) == 2
    results = {r["track"]: r for r in load_results(tmp_path / "results")}
    assert [Path(p).parent.name for p in written] == ["outdoor_tiny", "outdoor_tiny_later"]
    for result in results.values():
        assert result["score"]["n"] == 1 and result["score"]["higher_is_better"] is False
        assert list(result["per_world_seed"]) == ["300"]
    paper, later = (
        json.loads(next((tmp_path / "results/tasks" / name).rglob("300.json")).read_text())
        for name in ("outdoor_tiny", "outdoor_tiny_later")
    )
    for task in (paper, later):
        scores = task["output"]["scores"]
        assert math.isfinite(scores["score"]) and 0 < scores["score"] < 100
        assert scores["frames"]["train"] == 133 and scores["frames"]["test"] == 125
        assert scores["frames"]["unvisited"] > 0  # the test path crosses the south-west
        after = scores["conditions"]["after"]
        assert set(after) == {"all", "unvisited", "visited"}
        assert scores["parts"]["unvisited"] == pytest.approx(
            sum(after["unvisited"]["mae_percent"]) / 2
        )
    paper_scores, later_scores = paper["output"]["scores"], later["output"]["scores"]
    assert paper_scores["score"] == paper_scores["parts"]["after"]
    assert later_scores["score"] == later_scores["parts"]["later"]
    # the same method on the same drive: the reference "after" score is the paper track's
    assert later_scores["parts"]["after"] == paper_scores["parts"]["after"]
    assert later_scores["renders"]["drive"] == paper_scores["renders"]["drive"]
    # the result holds the parts, per world seed and their means
    assert results["outdoor_tiny"]["parts_per_world_seed"] == {"300": paper_scores["parts"]}
    assert results["outdoor_tiny_later"]["parts"] == later_scores["parts"]

    # the paper track's task was not run: its scores are a part of the later track's task,
    # and exactly what running it alone gives (same cache: nothing is rendered again)
    shared = json.loads((tmp_path / "results/tasks/outdoor_tiny/band_means/300.json").read_text())
    assert shared["provenance"]["scored_with"] == "outdoor_tiny_later / band_means / world seed 300"
    assert shared["output"]["seconds"] == 0.0
    run_sweep(tracks[:1], [(BAND_MEANS, {})], tmp_path / "alone", cache_dir=cache, verbose=False)
    alone = json.loads((tmp_path / "alone/tasks/outdoor_tiny/band_means/300.json").read_text())
    assert "scored_with" not in alone["provenance"] and alone["output"]["seconds"] > 0
    assert shared["output"]["scores"] == alone["output"]["scores"]
    assert shared["identity"] == alone["identity"]
    # a rerun of the shared sweep reuses both tasks
    again = run_sweep(
        tracks, [(BAND_MEANS, {})], tmp_path / "results", cache_dir=cache, verbose=False
    )
    assert again == written

    # the table lists each track's parts (conditions, unvisited region) below the scores
    table = write_table(tmp_path / "results")
    assert "outdoor_tiny_later: the parts of the score" in table
    assert "| method | source | after | unvisited |" in table
    assert "| method | source | after | later | unvisited |" in table
