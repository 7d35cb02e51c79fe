"""The omnidirectional camera: panorama geometry (:mod:`.projection`) and its renderer
(:mod:`.renderer`, imports MuJoCo and sets up OpenGL)."""

from __future__ import annotations

from sfa_gym.sim.camera.projection import PanoramaSpec, ViewDirections, camera_mjcf

__all__ = ["PanoramaSpec", "ViewDirections", "camera_mjcf"]
