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
from sfa_gym.rotation import Rotation, check_step
from sfa_gym.sfa import HierarchicalSFA, LayerSpec, WeightSharing, presets
from sfa_gym.sfa.spec import layer_grids

__all__ = [
    "EnvId",
    "NETWORKS",
    "RenderSettings",
    "NetworkName",
    "SFASettings",
    "WeightSharing",
    "check_choice",
    "check_choices",
    "check_env_id",
    "check_panorama",
    "check_world",
    "network_for",
]

NetworkName = Literal["auto", "paper_sim", "paper_outdoor", "tiny"]
"""Presets of :mod:`sfa_gym.sfa.presets` a protocol can train; ``auto``: the one made for the
panoramas' size (:func:`network_for`)."""

EnvId = Annotated[str, tyro.conf.arg(aliases=("--env",))]
"""A registered env id; on the command line ``--env-id`` or ``--env``."""


def network_for(height: int, width: int, node_dim: int) -> list[LayerSpec]:
    """The layers of the preset made for ``height x width`` panoramas: the first of paper_sim
    (40 x 350) and paper_outdoor (60 x 600) whose layers tile that size, else tiny (which
    fits any small panorama, or says why it does not)."""
    for name in ("paper_sim", "paper_outdoor"):
        layers = NETWORKS[name](height, width, node_dim)
        try:
            layer_grids(layers, height, width)
        except ValueError:
            continue
        return layers
    return NETWORKS["tiny"](height, width, node_dim)


NETWORKS: dict[str, Callable[[int, int, int], list[LayerSpec]]] = {
    "auto": network_for,
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


def check_choices(name: str, values: Any, choices: Any, item: str) -> None:
    """ValueError naming ``name`` unless ``values`` is a non-empty tuple (or list) of distinct
    values of the Literal type ``choices``; ``item`` names one of them in the message ("an
    evaluation")."""
    if not isinstance(values, tuple | list) or not values:
        raise ValueError(f"{name} must be a non-empty tuple, got {values!r}")
    for value in values:
        check_choice(name, value, choices)
    if len(set(values)) != len(values):
        raise ValueError(f"{name} {list(values)} repeats {item}")


def check_env_id(name: str, env_id: Any) -> None:
    """ValueError naming ``name`` unless ``env_id`` is a registered Gymnasium env id."""
    import gymnasium as gym

    import sfa_gym  # noqa: F401  (registers the sfa_gym ids)

    if not isinstance(env_id, str) or env_id not in gym.registry:
        ours = ", ".join(sorted(i for i in gym.registry if i.startswith("sfa_gym/")))
        raise ValueError(f"{name} {env_id!r} is not a registered env; the sfa-gym envs are {ours}")


def check_world(name: str, world: Any) -> None:
    """ValueError naming ``name`` unless ``world`` is None (the env's own world) or a world
    spec that loads (a name in envs/ or a JSON file)."""
    if world is None:
        return
    from sfa_gym.sim.worlds.spec import load_world_spec

    if not isinstance(world, str) or not world:
        raise ValueError(f"{name} must be None or a world spec name, got {world!r}")
    try:
        load_world_spec(world)
    except ValueError as error:
        raise ValueError(f"{name}: {error}") from None


def check_panorama(name: str, panorama: Any, step: int) -> None:
    """ValueError naming ``name`` unless ``panorama`` is None (the env's own camera) or
    ``(height, width)`` positive ints whose width is a multiple of the rotation ``step``."""
    if panorama is None:
        return
    if not isinstance(panorama, tuple | list) or len(panorama) != 2:
        raise ValueError(f"{name} must be None or (height, width) in pixels, got {panorama!r}")
    for value in panorama:
        check_positive_int(name, value)
    check_step(panorama[1], step)


@dataclass(frozen=True)
class RenderSettings:
    """What a protocol renders and how it turns the panoramas: the env, its world, its camera
    and the simulated rotation. The protocols' ``Config`` classes start with these fields."""

    env_id: EnvId = "sfa_gym/OmniRover-v0"
    """registered env to render the panoramas with"""
    world: str | None = None
    """world spec to render (a name in envs/ or a JSON file); None: the env's own world"""
    panorama: tuple[int, int] | None = None
    """(height, width) of the panoramas in pixels, replacing the env's camera (e.g. small
    panoramas for quick runs); None: the env's own camera"""
    step: int = 5
    """simulated rotation step, columns (must divide the panorama width)"""

    @property
    def rotation(self) -> Rotation:
        """The simulated rotation every method is trained and evaluated on."""
        return Rotation(step=self.step)

    def panorama_bytes(self) -> int:
        """Bytes of one panorama (with the env's own camera: the smallest of the registered
        envs', 40 x 350, a lower bound)."""
        height, width = (40, 350) if self.panorama is None else self.panorama
        return int(height) * int(width) * 3

    def validate_rendering(self) -> None:
        """Raise ValueError naming the first bad field of these."""
        check_env_id("env_id", self.env_id)
        check_world("world", self.world)
        check_positive_int("step", self.step)
        check_panorama("panorama", self.panorama, self.step)


@dataclass(frozen=True)
class SFASettings:
    """The hierarchical SFA network a protocol trains."""

    network: NetworkName = "paper_sim"
    """architecture: a preset of sfa_gym.sfa.presets (paper_sim: 40 x 350 panoramas, 4 layers;
    paper_outdoor: 60 x 600; tiny: any small panorama, 3 layers; auto: the one made for the
    panoramas' size)"""
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
