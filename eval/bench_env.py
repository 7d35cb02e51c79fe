"""Benchmark: rendering cost of the omnidirectional camera (and, later, env steps per second).

Camera part: in one process, time ``OmniCamera.render`` for several panorama specs on the
``paper_sim`` world with the rover (or, if the env's world builder is unavailable, a built-in
arena-like scene of similar complexity), and one ``mujoco.Renderer`` render of the same scene
with as many output pixels (W x H, with and without the model's MSAA, and at the supersampled
size). Reports wall and CPU milliseconds per render, renders per second per core (from CPU
time, which counts llvmpipe's rasteriser threads too) and the panorama / single-render ratio,
plus a breakdown of one panorama into its stages.

Targets: panorama (350 x 40) <= 1.5 x one W x H render and >= 400 renders/s per core.

The machine may be shared: every time is the best of ``--repeats`` batches. For per-core
numbers without llvmpipe's threads, run with ``LP_NUM_THREADS=0`` (rasterise in the calling
thread).

Usage (from the repository root)::

    .venv/bin/python eval/bench_env.py            # full table
    .venv/bin/python eval/bench_env.py --quick    # smoke run
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from sfa_gym import gl  # noqa: E402

gl.configure()

import cv2  # noqa: E402
import mujoco  # noqa: E402

from sfa_gym.camera import OmniCamera, PanoramaSpec, camera_mjcf  # noqa: E402

TARGETS = {"ratio_to_single_render_max": 1.5, "renders_per_s_per_core_min": 400.0}


@dataclass(frozen=True)
class Timing:
    """Best-of-repeats cost of one call: wall and process CPU milliseconds."""

    wall_ms: float
    cpu_ms: float

    @property
    def per_s_per_core(self) -> float:
        return 1000.0 / self.cpu_ms if self.cpu_ms > 0 else float("inf")


def time_calls(fn: Callable[[], object], n: int = 100, repeats: int = 5) -> Timing:
    """Best of ``repeats`` batches of ``n`` calls (after one warm-up call)."""
    fn()
    wall = cpu = float("inf")
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(n):
            fn()
        wall = min(wall, (time.perf_counter() - t0) / n * 1e3)
        cpu = min(cpu, (time.process_time() - c0) / n * 1e3)
    return Timing(wall, cpu)


# -- scenes -------------------------------------------------------------------------------------


def _fallback_arena_mjcf(spec: PanoramaSpec, seed: int = 0) -> str:
    """A 7 m walled arena with textured floor and panels, ~40 landmarks, skybox, three lights."""
    rng = np.random.default_rng(seed)
    geoms = []
    for side in range(4):
        for k in range(4):
            t = -2.625 + 1.75 * k
            x, y = [(3.55, t), (-3.55, t), (t, 3.55), (t, -3.55)][side]
            sx, sy = (0.05, 0.875) if side < 2 else (0.875, 0.05)
            geoms.append(
                f'<geom type="box" pos="{x} {y} 0.4" size="{sx} {sy} 0.4" material="panel{k}"/>'
            )
    for _ in range(40):
        a, r = rng.uniform(0, 2 * np.pi), rng.uniform(4.2, 8.0)
        h, w = rng.uniform(0.5, 3.0), rng.uniform(0.1, 0.8)
        kind = rng.choice(["box", "cylinder", "ellipsoid"])
        size = f"{w} {w} {h / 2}" if kind != "cylinder" else f"{w} {h / 2}"
        rgb = " ".join(f"{v:.2f}" for v in rng.uniform(0.2, 1.0, 3))
        geoms.append(
            f'<geom type="{kind}" pos="{r * np.cos(a):.3f} {r * np.sin(a):.3f} {h / 2:.3f}" '
            f'size="{size}" rgba="{rgb} 1"/>'
        )
    panels = "".join(
        f'<texture name="panel{k}" type="2d" builtin="checker" rgb1="{0.2 * k + 0.1} .5 .4" '
        f'rgb2=".8 .7 {0.2 * k + 0.1}" width="64" height="64"/>'
        f'<material name="panel{k}" texture="panel{k}" texrepeat="2 1"/>'
        for k in range(4)
    )
    return f"""<mujoco>
  <visual><quality shadowsize="0" numslices="16" numstacks="8" numquads="1"/>
    <headlight ambient=".4 .4 .4" diffuse="0 0 0" specular="0 0 0"/></visual>
  <asset>
    <texture name="floor" type="2d" builtin="checker" rgb1=".4 .4 .45" rgb2=".5 .5 .5"
             width="128" height="128"/>
    <material name="floor" texture="floor" texrepeat="4 4"/>
    <texture type="skybox" builtin="gradient" rgb1=".4 .6 .9" rgb2=".9 .9 .95" width="256"
             height="1536"/>
    {panels}
  </asset>
  <worldbody>
    <light directional="true" dir="-.5 -.3 -.8" diffuse=".45 .45 .45" castshadow="false"/>
    <light directional="true" dir=".6 -.4 -.6" diffuse=".35 .35 .35" castshadow="false"/>
    <light directional="true" dir="0 .8 -.6" diffuse=".3 .3 .3" castshadow="false"/>
    <geom type="plane" size="40 40 40" material="floor"/>
    {"".join(geoms)}
    <body name="mast" mocap="true" pos="0.3 -0.2 1.0">{camera_mjcf(spec)}</body>
  </worldbody>
</mujoco>"""


def arena_model(
    spec: PanoramaSpec, world: str = "paper_sim", world_seed: int = 0
) -> tuple[mujoco.MjModel, mujoco.MjData, str]:
    """Model and data of ``world`` with the rover carrying cameras for ``spec``.

    Returns ``(model, data, description)``. Falls back to :func:`_fallback_arena_mjcf` when
    the env's world builder cannot be imported.
    """
    try:
        from sfa_gym.rover import RoverSpec, rover_mjcf
        from sfa_gym.worlds import build_world, load_world_spec

        mjcf = build_world(
            load_world_spec(world), world_seed, robot=rover_mjcf(RoverSpec(), spec)
        ).mjcf
        name = f"{world} (seed {world_seed}) + rover"
    except ImportError:
        mjcf = _fallback_arena_mjcf(spec, world_seed)
        name = "built-in arena-like scene"
    model = mujoco.MjModel.from_xml_string(mjcf)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data, name


# -- camera benchmark ---------------------------------------------------------------------------


def bench_panorama(spec: PanoramaSpec, n: int = 100, repeats: int = 5) -> Timing:
    """Cost of one ``OmniCamera.render`` for ``spec`` (GL context creation excluded)."""
    model, data, _ = arena_model(spec)
    camera = OmniCamera(model, spec)
    try:
        return time_calls(lambda: camera.render(data), n, repeats)
    finally:
        camera.close()


def bench_single_render(
    spec: PanoramaSpec,
    width: int,
    height: int,
    msaa: bool,
    n: int = 100,
    repeats: int = 5,
) -> Timing:
    """Cost of ``update_scene`` + ``render`` of one ``mujoco.Renderer`` of width x height,
    looking along the rover's heading, with the model's MSAA samples or without MSAA."""
    model, data, _ = arena_model(spec)
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    if not msaa:
        model.vis.quality.offsamples = 0
    renderer = mujoco.Renderer(model, height, width)
    camera = "omni0"

    def render() -> None:
        renderer.update_scene(data, camera=camera)
        renderer.render()

    try:
        return time_calls(render, n, repeats)
    finally:
        renderer.close()


def panorama_breakdown(spec: PanoramaSpec, n: int = 100, repeats: int = 5) -> dict[str, Timing]:
    """Cost of the stages of one panorama: scene update, per-view rendering + readPixels
    (llvmpipe rasterises lazily, at the read), remap, box filter.

    Calls the camera's private stages directly; keep in step with ``sfa_gym/camera.py``.
    """
    model, data, _ = arena_model(spec)
    cam = OmniCamera(model, spec)
    cam.render(data)
    scn, con = cam._scene, cam._con
    cat = mujoco.mjtCatBit.mjCAT_ALL

    def update() -> None:
        mujoco.mjv_updateScene(model, data, cam._option, cam._perturb, cam._cameras[0], cat, scn)
        cam._headlight_at_eye()

    def views() -> None:
        update()
        cam._render_views(data)
        mujoco.mjr_readPixels(cam._buffer, None, cam._full_rect, con)

    def remap() -> None:
        cv2.remap(cam._buffer, cam._map_x, cam._map_y, cv2.INTER_LINEAR, dst=cam._fine)

    size = (spec.width, spec.height)
    out = {
        "scene update": time_calls(update, n, repeats),
        "views + readPixels": time_calls(views, n, repeats),
        "remap": time_calls(remap, n, repeats),
        "box filter": time_calls(
            lambda: cv2.resize(cam._fine, size, interpolation=cv2.INTER_AREA), n, repeats
        ),
        "total": time_calls(lambda: cam.render(data), n, repeats),
    }
    cam.close()
    return out


def _spec_label(spec: PanoramaSpec) -> str:
    return f"{spec.width}x{spec.height} N={spec.n_views} ss={spec.supersample}"


def camera_table(
    specs: list[PanoramaSpec], n: int = 100, repeats: int = 5
) -> tuple[list[dict[str, object]], dict[str, bool]]:
    """Rows (one per spec and per single-render reference) and the target checks."""
    rows: list[dict[str, object]] = []
    checks: dict[str, bool] = {}
    references: dict[tuple[int, int], dict[str, Timing]] = {}
    for spec in specs:
        key = (spec.width, spec.height)
        if key not in references:
            ss_spec = replace(spec, supersample=2)
            references[key] = {
                f"Renderer {spec.width}x{spec.height}": bench_single_render(
                    spec, spec.width, spec.height, msaa=False, n=n, repeats=repeats
                ),
                f"Renderer {spec.width}x{spec.height} MSAA": bench_single_render(
                    spec, spec.width, spec.height, msaa=True, n=n, repeats=repeats
                ),
                f"Renderer {2 * spec.width}x{2 * spec.height}": bench_single_render(
                    ss_spec, 2 * spec.width, 2 * spec.height, msaa=False, n=n, repeats=repeats
                ),
            }
            for name, t in references[key].items():
                rows.append({"what": name, "timing": t, "ratio": None, "ratio_msaa": None})
        refs = references[key]
        plain = refs[f"Renderer {spec.width}x{spec.height}"]
        msaa = refs[f"Renderer {spec.width}x{spec.height} MSAA"]
        t = bench_panorama(spec, n=n, repeats=repeats)
        ratio, ratio_msaa = t.cpu_ms / plain.cpu_ms, t.cpu_ms / msaa.cpu_ms
        rows.append(
            {
                "what": f"panorama {_spec_label(spec)}",
                "timing": t,
                "ratio": ratio,
                "ratio_msaa": ratio_msaa,
            }
        )
        if spec == PanoramaSpec.paper_sim():
            checks["ratio <= 1.5 (vs W x H render, no MSAA)"] = (
                ratio <= TARGETS["ratio_to_single_render_max"]
            )
            checks["ratio <= 1.5 (vs W x H render with MSAA)"] = (
                ratio_msaa <= TARGETS["ratio_to_single_render_max"]
            )
            checks[">= 400 renders/s per core (350x40)"] = (
                t.per_s_per_core >= TARGETS["renders_per_s_per_core_min"]
            )
    return rows, checks


def format_camera_table(rows: list[dict[str, object]]) -> str:
    lines = [
        f"{'render':42s} {'wall ms':>8s} {'cpu ms':>8s} {'/s/core':>8s} {'x single':>9s} "
        f"{'x MSAA':>7s}",
    ]
    for row in rows:
        t = row["timing"]
        assert isinstance(t, Timing)
        ratio = "" if row["ratio"] is None else f"{row['ratio']:.2f}"
        ratio_msaa = "" if row["ratio_msaa"] is None else f"{row['ratio_msaa']:.2f}"
        lines.append(
            f"{row['what']:42s} {t.wall_ms:8.2f} {t.cpu_ms:8.2f} {t.per_s_per_core:8.0f} "
            f"{ratio:>9s} {ratio_msaa:>7s}"
        )
    return "\n".join(lines)


def format_breakdown(spec: PanoramaSpec, stages: dict[str, Timing]) -> str:
    lines = [f"stages of one panorama {_spec_label(spec)} (cpu ms):"]
    lines += [f"  {name:22s} {t.cpu_ms:7.3f}" for name, t in stages.items()]
    return "\n".join(lines)


def camera_specs(quick: bool = False) -> list[PanoramaSpec]:
    sim, outdoor = PanoramaSpec.paper_sim(), PanoramaSpec.paper_outdoor()
    if quick:
        return [sim]
    return [
        sim,
        replace(sim, supersample=1),
        replace(sim, n_views=6),
        replace(sim, n_views=6, supersample=1),
        outdoor,
        replace(outdoor, supersample=1),
        replace(outdoor, n_views=6),
    ]


# -- env benchmark ------------------------------------------------------------------------------


def bench_env_steps(panorama: str, n: int = 100, repeats: int = 5) -> tuple[Timing, Timing]:
    """Cost of one ``OmniRoverEnv.step`` (physics for one control period + one panorama) and
    of its physics alone, for a panorama preset ("paper_sim" or "paper_outdoor").

    The rover drives a slow circle so that it keeps moving and stays inside the arena.
    """
    from sfa_gym.env import OmniRoverEnv

    env = OmniRoverEnv(panorama=panorama)
    env.reset(seed=0, options={"pose": (0.0, -1.0, 0.0)})
    action = np.array([0.3, 0.3], dtype=np.float32)
    try:
        step = time_calls(lambda: env.step(action), n, repeats)
        physics = time_calls(
            lambda: mujoco.mj_step(env.model, env.data, nstep=env.frame_skip), n, repeats
        )
    finally:
        env.close()
    return step, physics


def format_env_table(n: int = 100, repeats: int = 5) -> str:
    lines = [
        f"{'env step (control period 0.1 s)':42s} {'wall ms':>8s} {'cpu ms':>8s} {'/s/core':>8s}"
    ]
    for preset in ("paper_sim", "paper_outdoor"):
        spec = getattr(PanoramaSpec, preset)()
        step, physics = bench_env_steps(preset, n=n, repeats=repeats)
        for what, t in (
            (f"step {spec.width}x{spec.height}", step),
            ("  of which physics", physics),
        ):
            lines.append(f"{what:42s} {t.wall_ms:8.2f} {t.cpu_ms:8.2f} {t.per_s_per_core:8.0f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="one spec, few calls (smoke run)")
    parser.add_argument("--n", type=int, default=100, help="calls per timed batch")
    parser.add_argument("--repeats", type=int, default=5, help="batches; the best one counts")
    args = parser.parse_args(argv)
    n, repeats = (10, 2) if args.quick else (args.n, args.repeats)
    spec = PanoramaSpec.paper_sim()
    _, _, scene = arena_model(spec)
    print(
        f"scene: {scene}; GL: {os.environ.get('MUJOCO_GL')}; "
        f"LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', 'default')}; "
        f"best of {repeats} x {n} calls"
    )
    rows, checks = camera_table(camera_specs(args.quick), n=n, repeats=repeats)
    print(format_camera_table(rows))
    print(format_breakdown(spec, panorama_breakdown(spec, n=n, repeats=repeats)))
    for name, ok in checks.items():
        print(f"target {name}: {'met' if ok else 'NOT met'}")
    print(format_env_table(n=n, repeats=repeats))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
