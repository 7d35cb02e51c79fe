"""``sfa-gym localize-outdoor``: the outdoor protocol (:mod:`sfa_gym.protocols.outdoor`) for
hierarchical SFA and the plug-in feature methods, with its output folder, results and figures.

The runs are recorded into the output folder (``drive.run``, ``test_<condition>.run``,
``train_<hours>h.run``; ``test_later+2h.run`` and so on for several offsets) and reused or
resumed by the next call. Hierarchical SFA comes first,
with the paper's linear regression, a quadratic one and the map decoder, and its linear
regression is also scored on every rotation window (what the fewer windows cost); each plug-in
with its regressions. Scoring is the protocol's :func:`~sfa_gym.protocols.outdoor.score_on`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sfa_gym._checks import check_world_seed
from sfa_gym.experiments.common import FIGURE_REGRESSOR, methods_with_sfa
from sfa_gym.experiments.report import check_out_folder, results_header, write_results
from sfa_gym.experiments.trajectory import PAPER_OUTDOOR_RESULTS
from sfa_gym.plugins import FeatureMethod
from sfa_gym.protocols import outdoor as protocol
from sfa_gym.protocols.outdoor import CONDITIONS, interleave
from sfa_gym.protocols.settings import SFASettings

__all__ = ["CONDITIONS", "OutdoorExperiment", "interleave", "run_outdoor_experiment"]


@dataclass(frozen=True)
class OutdoorExperiment(protocol.Config):
    """Settings of the outdoor protocol (defaults: the paper's), a world and the SFA network."""

    world_seed: int = 0
    """seed of the world's procedural variation (scenery, clouds, movers)"""
    sfa: SFASettings = SFASettings(network="auto")
    """the hierarchical SFA network (auto: paper_outdoor at the paper's 60 x 600, paper_sim at
    40 x 350)"""

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        check_world_seed("world_seed", self.world_seed)
        super().validate()
        self.sfa.validate()


class FolderRuns:
    """The runs of an output folder, recorded there under readable names (``drive.run``,
    ``test_<condition>.run``, ``train_<hours>h.run``) and resumed when incomplete: the
    :class:`~sfa_gym.protocols.RunSource` of the command line."""

    def __init__(self, out: Path, config: protocol.Config, world_seed: int, progress: bool):
        self.progress = progress
        self.default_panorama = config.panorama is None
        self.paths = {}
        for name, request in protocol.requests(config, world_seed).items():
            file = name if name.startswith(("drive", "train_")) else f"test_{name}"
            self.paths[request.key()] = out / f"{file}.run"

    def get(self, request: Any) -> Any:
        from sfa_gym.recording.recorder import record

        kwargs = {"world_seed": request.world_seed, **request.env_kwargs}
        if not self.default_panorama:
            kwargs["panorama"] = request.panorama_spec()
        return record(
            request.env_id,
            request.driver,
            self.paths[request.key()],
            seed=request.seed,
            env_kwargs=kwargs,
            progress=self.progress,
        )


def run_outdoor_experiment(
    config: OutdoorExperiment,
    out_dir: str | os.PathLike[str],
    methods: Sequence[tuple[FeatureMethod, Sequence[str]]] = (),
    progress: bool = True,
    figures: bool = True,
) -> dict[str, Any]:
    """Run the outdoor protocol; write ``results.json``, ``sfa_model.npz`` and figures.

    Args:
        config: the protocol's settings.
        out_dir: output folder (created); the runs are kept there (``drive.run``,
            ``test_<condition>.run``) and reused or resumed by the next call.
        methods: extra feature methods with their regressions (plug-ins); hierarchical SFA
            comes first, with the paper's linear regression, a quadratic one and the map
            decoder.
        progress: progress bars.
        figures: write the PNG figures (trajectories, estimates, error map, firing maps).

    Returns:
        The results, as written to ``results.json``: per method its ``eta_r``, ``eta_phi`` and
        per regression and condition the MAE over ``all`` test frames, the ``unvisited``
        region and the ``visited`` rest (percentages of the ``after`` test run's range).
    """
    from sfa_gym.sfa.io import save_model

    config.validate()
    out = Path(out_dir)
    check_out_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    runs = FolderRuns(out, config, config.world_seed, progress)
    data = protocol.load_data(config, config.world_seed, runs)
    evaluated = methods_with_sfa(config.sfa, config.rotation, methods, progress)
    found: dict[str, Any] = {}
    for i, (method, regressors) in enumerate(evaluated):
        scores = protocol.score_on(config, method, data, regressors, i == 0, progress)
        found[method.name] = scores.entry()
        if i == 0:
            sfa = scores

    drive, n = data.runs["drive"], config.train_frames
    results: dict[str, Any] = {
        **results_header("outdoor", config, data.train_pan.shape[2], config.step),
        "eval_windows": data.windows.tolist(),
        "unvisited_region": [float(v) for v in data.region],
        "runs": {
            "train": _run_summary(drive, slice(0, n)),
            "after": _run_summary(drive, slice(n, None)),
            **{
                c: _run_summary(data.runs[c], slice(None))
                for c in config.test_conditions
                if c != "after"
            },
        },
        "paper": PAPER_OUTDOOR_RESULTS,
        "methods": found,
    }
    model = sfa.method.model_
    save_model(model, out / "sfa_model.npz")
    results = write_results(out / "results.json", results)
    if figures:
        from sfa_gym.experiments.figures import trajectory_figures

        every = max(1, len(data.train_pan) // 1500)  # firing maps: 1500 frames are plenty
        after = data.tests["after"]
        trajectory_figures(
            out,
            exclude=data.region,
            model=model,
            rotation=config.rotation,
            train_run=_Part(drive, slice(0, n)),
            test_run=_Part(drive, slice(n, None)),
            train_pan=data.train_pan[::every],
            train_xy=data.train_xy[::every],
            test_xy=after.xy,
            test_time=after.time,
            estimates=sfa.estimates[FIGURE_REGRESSOR]["after"],
        )
    return results


@dataclass
class _Part:
    """Frames ``part`` of a run, as the trajectory figures read a run."""

    run: Any
    part: slice

    @property
    def poses(self) -> NDArray[np.float64]:
        return self.run.poses[self.part]

    @property
    def metadata(self) -> dict[str, Any]:
        return self.run.metadata

    def __len__(self) -> int:
        return len(self.poses)


def _run_summary(run: Any, part: slice) -> dict[str, Any]:
    xy, time = run.poses[part, :2], run.time[part]
    return {
        "path": run.path.name,
        "frames": [part.start or 0, (part.start or 0) + len(xy)],
        "run_start_hour": run.metadata["env_kwargs"].get("start_hour"),
        "start_s": float(time[0]),
        "duration_s": float(time[-1] - time[0]),
        "distance_m": round(float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum()), 3),
        "end_reason": run.metadata.get("end_reason"),
    }
