"""Settings shared by the localization protocols: the hierarchical SFA network (one nested
dataclass, :class:`SFASettings`) and the checks of the values every protocol has.

The protocols' settings are frozen dataclasses with a docstring under each field; the command
line (:mod:`sfa_gym.cli`) is generated from them, so a field added here is an option there, with
its docstring as help. ``validate()`` is the one place where their values are checked.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any, Literal, get_args

import tyro

from sfa_gym._checks import check_positive_int
from sfa_gym.sfa import HierarchicalSFA, LayerSpec, WeightSharing, presets

__all__ = [
    "EnvId",
    "NETWORKS",
    "NetworkName",
    "SFASettings",
    "WeightSharing",
    "check_choice",
    "check_env_id",
]

NetworkName = Literal["paper_sim", "paper_outdoor", "tiny"]
"""Presets of :mod:`sfa_gym.sfa.presets` a protocol can train."""

EnvId = Annotated[str, tyro.conf.arg(aliases=("--env",))]
"""A registered env id; on the command line ``--env-id`` or ``--env``."""

NETWORKS: dict[str, Callable[[int, int, int], list[LayerSpec]]] = {
    "paper_sim": lambda h, w, d: presets.paper_sim(dim=d, out_dim=d),
    "paper_outdoor": lambda h, w, d: presets.paper_outdoor(dim=d, out_dim=d),
    "tiny": lambda h, w, d: presets.tiny(height=h, width=w, dim=d, out_dim=d),
}
"""The layers of each :data:`NetworkName` for panoramas ``h x w`` and node dimension ``d``."""


def check_choice(name: str, value: Any, choices: Any) -> None:
    """ValueError naming ``name`` unless ``value`` is one of the Literal type ``choices``."""
    allowed = get_args(choices)
    if value not in allowed:
        raise ValueError(f"{name} must be one of {list(allowed)}, got {value!r}")


def check_env_id(name: str, env_id: Any) -> None:
    """ValueError naming ``name`` unless ``env_id`` is a registered Gymnasium env id."""
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the sfa_gym ids)

    if not isinstance(env_id, str) or env_id not in gym.registry:
        ours = ", ".join(sorted(i for i in gym.registry if i.startswith("sfa_gym/")))
        raise ValueError(f"{name} {env_id!r} is not a registered env; the sfa-gym envs are {ours}")


@dataclass(frozen=True)
class SFASettings:
    """The hierarchical SFA network a protocol trains."""

    network: NetworkName = "paper_sim"
    """architecture: a preset of sfa_gym.sfa.presets (paper_sim: 40 x 350 panoramas, 4 layers;
    paper_outdoor: 60 x 600; tiny: any small panorama, 3 layers)"""
    node_dim: int = 32
    """linear SFA dimension and output dimension of every node"""
    n_outputs: int = 8
    """slow features used (the paper: 8)"""
    weight_sharing: WeightSharing = "rows"
    """nodes that share weights: "rows" (one node per row of each layer's grid: rows see sky,
    horizon or ground, while along the width every position sees the same patches once all
    rotations are trained on), "layer" (one node per layer, the paper) or "none" (one per
    position; no rotation shortcut, slow)"""

    def validate(self) -> None:
        """Raise ValueError naming the first bad setting."""
        check_choice("network", self.network, NetworkName)
        check_positive_int("node_dim", self.node_dim)
        check_positive_int("n_outputs", self.n_outputs)
        check_choice("weight_sharing", self.weight_sharing, WeightSharing)

    def make_model(self, height: int, width: int, progress: bool = True) -> HierarchicalSFA:
        """An unfitted network for panoramas ``height x width`` pixels."""
        self.validate()
        return HierarchicalSFA(
            NETWORKS[self.network](height, width, self.node_dim),
            n_outputs=self.n_outputs,
            weight_sharing=self.weight_sharing,
            progress=progress,
        )
