"""The omnidirectional camera: panorama geometry (:mod:`.projection`), its renderer
(:mod:`.renderer`, imports MuJoCo and sets up OpenGL) and the catadioptric mirror camera
(:mod:`.mirror`; its renderer imports MuJoCo on construction)."""

from __future__ import annotations

from sfa_gym.sim.camera.mirror import MirrorCamera, MirrorSpec, UnwarpRows, unwarp
from sfa_gym.sim.camera.projection import PanoramaSpec, ViewDirections, camera_mjcf

__all__ = [
    "MirrorCamera",
    "MirrorSpec",
    "PanoramaSpec",
    "UnwarpRows",
    "ViewDirections",
    "camera_mjcf",
    "unwarp",
]
