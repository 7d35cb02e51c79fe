"""Parts shared by the localization protocols: hierarchical SFA as a feature method, features of
every rotated view, fitting a method on a training sequence, result formatting."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

import sfa_gym
from sfa_gym.localization import eta_phi, eta_r
from sfa_gym.localization.methods import FeatureMethod
from sfa_gym.rotation import n_rotations, rotated_views
from sfa_gym.sfa import HierarchicalSFA, presets

FIGURE_REGRESSOR = "map"
"""The regression whose SFA estimates the estimate and error-map figures show."""

NETWORKS = {
    "paper_sim": lambda h, w, d: presets.paper_sim(dim=d, out_dim=d),
    "paper_outdoor": lambda h, w, d: presets.paper_outdoor(dim=d, out_dim=d),
    "tiny": lambda h, w, d: presets.tiny(height=h, width=w, dim=d, out_dim=d),
}

WEIGHT_SHARING = {"layer": True, "rows": "rows", "none": False}
"""Names of the weight-sharing modes of :class:`~sfa_gym.sfa.HierarchicalSFA` in the protocols'
settings and on the command line."""


def check_sfa_settings(config: Any) -> None:
    """Raise ValueError if a protocol's ``network`` or ``weight_sharing`` is unknown."""
    if config.network not in NETWORKS:
        raise ValueError(f"network must be one of {sorted(NETWORKS)}, got {config.network!r}")
    if config.weight_sharing not in WEIGHT_SHARING:
        raise ValueError(
            f"weight_sharing must be one of {sorted(WEIGHT_SHARING)}, got {config.weight_sharing!r}"
        )


class SlowFeatureMethod:
    """Hierarchical SFA as a feature method: fitted on all simulated rotations of a sequence of
    panoramas (:meth:`HierarchicalSFA.fit_rotations`), regressed linearly as in the paper."""

    name = "hierarchical_sfa"
    regressor = "linear"

    def __init__(
        self,
        network: str = "paper_sim",
        node_dim: int = 32,
        n_outputs: int = 8,
        step: int = 5,
        weight_sharing: str = "rows",
        progress: bool = True,
    ) -> None:
        self.network = network
        self.node_dim = node_dim
        self.n_outputs = n_outputs
        self.step = step
        self.weight_sharing = weight_sharing
        self.progress = progress

    def _new_model(self, h: int, w: int) -> HierarchicalSFA:
        return HierarchicalSFA(
            NETWORKS[self.network](h, w, self.node_dim),
            n_outputs=self.n_outputs,
            weight_sharing=WEIGHT_SHARING[self.weight_sharing],
            progress=self.progress,
        )

    def fit_rotations(self, panoramas: NDArray[np.uint8]) -> SlowFeatureMethod:
        """Fit on ``panoramas (L, H, W, 3)`` in visiting order, with all their rotations."""
        _, h, w, _ = panoramas.shape
        self.model_ = self._new_model(h, w).fit_rotations(panoramas, step=self.step)
        self.input_shape_ = self.model_.input_shape_
        return self

    def fit(self, views: NDArray[np.uint8], sequence_ids: Any = None) -> SlowFeatureMethod:
        _, h, w, _ = views.shape
        self.model_ = self._new_model(h, w).fit(views, sequence_ids)
        self.input_shape_ = self.model_.input_shape_
        return self

    def transform(self, views: NDArray[np.uint8]) -> NDArray[np.float64]:
        return self.model_.transform(views)

    def transform_rotations(self, panoramas: NDArray[np.uint8], step: int) -> NDArray[np.float64]:
        """Features of every rotation of every panorama, ``(L, K, n_outputs)``, computed with
        the rotation shortcut (the lower layers run once per panorama)."""
        return self.model_.transform_rotations(panoramas, step=step)


def rotation_features(
    method: FeatureMethod, panoramas: NDArray[np.uint8], step: int, desc: str, progress: bool
) -> NDArray[np.float64]:
    """Features of every rotated view, ``(L, K, k)``, a few locations at a time.

    A method with ``transform_rotations(panoramas, step)`` computes them itself (hierarchical
    SFA exploits that a rotation permutes its layer-1 patches); the others see every view.
    """
    n_rot = n_rotations(panoramas.shape[2], step)
    per_chunk = max(1, 4096 // n_rot)
    out = []
    for i in tqdm(range(0, len(panoramas), per_chunk), desc=desc, disable=not progress):
        block = panoramas[i : i + per_chunk]
        if hasattr(method, "transform_rotations"):
            features = method.transform_rotations(block, step)
        else:
            views = np.concatenate([rotated_views(p, step)[0] for p in block])
            features = method.transform(views)
        out.append(np.asarray(features, dtype=np.float64).reshape(len(block), n_rot, -1))
    return np.concatenate(out)


def fit_method(method: FeatureMethod, panoramas: NDArray[np.uint8], step: int) -> FeatureMethod:
    if hasattr(method, "fit_rotations"):
        return method.fit_rotations(panoramas)
    views = np.concatenate([rotated_views(p, step)[0] for p in panoramas])
    return method.fit(views)


def mae_dict(result: Any) -> dict[str, list[float]]:
    return {
        "mae_m": np.round(result.mae_m, 5).tolist(),
        "mae_percent": np.round(result.mae_percent, 4).tolist(),
        "std_m": np.round(result.std_m, 5).tolist(),
        "range_m": np.round(result.range_m, 5).tolist(),
    }


def format_table(results: dict[str, Any]) -> str:
    """A plain-text table of the MAE per method and regression, for either protocol.

    Grid protocol: MAE in % of the range over the paper's random splits and fitted on the
    training positions. Trajectory protocol: MAE on the test run in metres and %, its standard
    deviation, and the MAE in % over the test frames in the region never visited in training.
    The last row is the paper's.
    """
    if results.get("protocol") == "trajectory":
        return _format_trajectory_table(results)
    lines = [
        f"{'method':<20} {'regression':<10} {'splits x %':>10} {'splits y %':>10} "
        f"{'test x %':>9} {'test y %':>9} {'max eta_phi':>11}"
    ]
    for name, entry in results["methods"].items():
        for reg, value in entry.items():
            if not isinstance(value, dict):
                continue
            s = value["paper_splits"]["mae_percent"]
            t = value["train_test"]["mae_percent"]
            lines.append(
                f"{name:<20} {reg:<10} {s[0]:>10.2f} {s[1]:>10.2f} {t[0]:>9.2f} {t[1]:>9.2f} "
                f"{max(entry['eta_phi']):>11.3f}"
            )
    paper = results["paper"]
    lines.append(
        f"{'paper (2013)':<20} {'linear':<10} {paper['mae_percent'][0]:>10.2f} "
        f"{paper['mae_percent'][1]:>10.2f} {'-':>9} {'-':>9} {paper['eta_phi_max']:>11.3f}"
    )
    return "\n".join(lines)


def _format_trajectory_table(results: dict[str, Any]) -> str:
    head = (
        f"{'method':<20} {'regression':<10} {'x m':>6} {'y m':>6} {'x %':>6} {'y %':>6} "
        f"{'std x':>6} {'std y':>6} {'excl x %':>8} {'excl y %':>8} {'max eta_phi':>11}"
    )
    lines = [head]

    def row(name, reg, t, excluded, eta_phi_max) -> str:
        e = ("-", "-") if excluded is None else [f"{v:.2f}" for v in excluded["mae_percent"]]
        return (
            f"{name:<20} {reg:<10} {t['mae_m'][0]:>6.3f} {t['mae_m'][1]:>6.3f} "
            f"{t['mae_percent'][0]:>6.2f} {t['mae_percent'][1]:>6.2f} "
            f"{t['std_m'][0]:>6.3f} {t['std_m'][1]:>6.3f} {e[0]:>8} {e[1]:>8} "
            f"{eta_phi_max:>11.3f}"
        )

    for name, entry in results["methods"].items():
        for reg, value in entry.items():
            if isinstance(value, dict):
                lines.append(
                    row(name, reg, value["train_test"], value["excluded"], max(entry["eta_phi"]))
                )
    lines.append(
        row("paper (2013)", "linear", results["paper"], None, results["paper"]["eta_phi_max"])
    )
    return "\n".join(lines)


def methods_with_sfa(
    config: Any, methods: Sequence[tuple[FeatureMethod, Sequence[str]]], progress: bool
) -> tuple[SlowFeatureMethod, list[tuple[FeatureMethod, Sequence[str]]]]:
    """Hierarchical SFA built from a protocol's ``config`` (evaluated with the paper's linear
    regression, a quadratic one and the map decoder), followed by the extra ``methods``."""
    sfa = SlowFeatureMethod(
        config.network,
        config.node_dim,
        config.n_outputs,
        config.step,
        weight_sharing=config.weight_sharing,
        progress=progress,
    )
    return sfa, [(sfa, ("linear", "quadratic", "map")), *methods]


def results_header(protocol: str, config: Any, width: int) -> dict[str, Any]:
    """The common head of a protocol's ``results.json``."""
    return {
        "format": "sfa-gym-localization",
        "version": 1,
        "sfa_gym_version": sfa_gym.__version__,
        "protocol": protocol,
        "config": dataclasses.asdict(config),
        "n_rotations": n_rotations(width, config.step),
    }


def invariance_entry(train_features: NDArray[np.float64]) -> dict[str, Any]:
    """eta_r, eta_phi per output and the feature count, from ``(L, K, k)`` training features."""
    return {
        "eta_r": np.round(eta_r(train_features), 4).tolist(),
        "eta_phi": np.round(eta_phi(train_features), 4).tolist(),
        "n_features": int(train_features.shape[2]),
    }
