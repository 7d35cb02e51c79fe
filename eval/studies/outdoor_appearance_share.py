"""How much of each slow feature codes appearance rather than place, and whether a regression
that leaves out the most appearance-coding outputs localizes better.

    .venv/bin/python -m eval.studies.outdoor_appearance_share --out results/outdoor_ta

reads a folder written by ``sfa-gym localize-outdoor --train-also H ...`` (its ``sfa_model.npz``
and runs). The training path was driven several times at different hours, frame for frame at
the same poses, so the difference between two runs' features at the same frame is appearance
alone (light, movers, noise). For each output it reports the *appearance share*:
``var(f_a - f_b) / 2`` over the variance of the output across the interleaved training
frames (0: the output is the same whenever the rover is at a place; 1: it codes only the time
of day). Then it fits the map decoder (the outdoor table's best SFA regression) on all outputs
and on the outputs left after dropping the 1, 2 and 3 with the largest share, and scores each
on every test run of the folder, as the experiment does (its rotation windows per frame).
Writes ``appearance_share.json`` into the folder.

Backs docs/outdoor.md (the outputs that code the time of day). Run from the repository root.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro

from sfa_gym.files import write_json_atomic


@dataclass(frozen=True)
class Args:
    out: Path = Path("results/outdoor_ta")
    """folder of a ``sfa-gym localize-outdoor --train-also ...`` run"""
    drop: tuple[int, ...] = (1, 2, 3)
    """numbers of the most appearance-coding outputs left out of the regression"""


def main(args: Args) -> None:
    from sfa_gym.features import view_features
    from sfa_gym.geometry import in_rectangle
    from sfa_gym.localization import mae, make_regressor, predict_locations
    from sfa_gym.protocols.outdoor import interleave
    from sfa_gym.recording.runfile import load_run
    from sfa_gym.rotation import Rotation, spread_indices
    from sfa_gym.sfa.io import load_model

    results = json.loads((args.out / "results.json").read_text())
    config = results["config"]
    if not config["train_also"]:
        raise SystemExit(
            f"{args.out} holds a run without --train-also: there is no second drive of the "
            "training path to tell appearance from place"
        )
    if config["normalise"] != "none":
        raise SystemExit(f"{args.out} normalised its panoramas ({config['normalise']}): not read")
    model = load_model(args.out / "sfa_model.npz")
    n = config["train_frames"]
    drive = load_run(args.out / "drive.run")
    rotation = Rotation(step=config["step"])
    windows = spread_indices(rotation.n_views(drive.panoramas.shape[2]), config["eval_rotations"])

    def features(panoramas, desc: str) -> np.ndarray:
        return view_features(model, panoramas, rotation, windows, desc)

    train = [features(drive.panoramas[:n], "train")]
    for hours in config["train_also"]:
        run = load_run(args.out / f"train_{hours:+g}h.run")
        train.append(features(run.panoramas, f"train {hours:+g} h"))
    xy_train = np.asarray(drive.poses[:n, :2], dtype=np.float64)

    # per frame the mean over the windows: the rotation is not what is asked about here
    per_frame = [f.mean(axis=1) for f in train]
    every = np.concatenate([f.reshape(-1, f.shape[2]) for f in train])
    between = np.mean([(per_frame[0] - f).var(axis=0) / 2 for f in per_frame[1:]], axis=0)
    share = between / every.var(axis=0)
    order = np.argsort(share)[::-1]  # most appearance-coding first

    tests = {"after": (drive.panoramas[n:], drive.poses[n:, :2])}
    for path in sorted(args.out.glob("test_*.run")):
        run = load_run(path)
        tests[path.name[len("test_") : -len(".run")]] = (run.panoramas, run.poses[:, :2])
    f_tests = {c: features(p, c) for c, (p, _) in tests.items()}
    xy_after = np.asarray(tests["after"][1], dtype=np.float64)
    test_range = xy_after.max(axis=0) - xy_after.min(axis=0)
    region = results["unvisited_region"]

    f_train = interleave(train)
    xy = np.repeat(interleave([xy_train] * len(train)), len(windows), axis=0)
    scores = {}
    for dropped in (0, *args.drop):
        keep = np.sort(order[dropped:])
        decoder = make_regressor("map").fit(f_train[..., keep].reshape(-1, len(keep)), xy)
        entry = {"outputs": (keep + 1).tolist()}
        for condition, (_, positions) in tests.items():
            positions = np.asarray(positions, dtype=np.float64)
            estimates = predict_locations(decoder, f_tests[condition][..., keep])
            inside = in_rectangle(positions, region)
            entry[condition] = {
                "all": mae(estimates, positions, coordinate_range=test_range).mae_percent.tolist(),
                "unvisited": mae(
                    estimates[inside], positions[inside], coordinate_range=test_range
                ).mae_percent.tolist(),
            }
        scores[f"drop {dropped}"] = entry

    found = {"appearance_share": share.tolist(), "map_decoder": scores}
    write_json_atomic(args.out / "appearance_share.json", found)
    print("appearance share per output:", " ".join(f"{s:.4f}" for s in share))
    for name, entry in scores.items():
        cells = " | ".join(
            f"{c} {a[0]:.2f}/{a[1]:.2f}"
            for c, v in entry.items()
            if c != "outputs"
            for a in (v["all"],)
        )
        print(f"map decoder, {name} (outputs {entry['outputs']}): {cells}")


if __name__ == "__main__":
    main(tyro.cli(Args))
