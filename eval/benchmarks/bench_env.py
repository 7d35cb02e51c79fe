"""Benchmark: env steps per second and the cost of the omnidirectional camera.

Measures, in one process (see issue "Benchmark"):

* env steps/s per core at 350x40 and 600x60: ``OmniRoverEnv.step`` (physics for one control
  period + one panorama), from process CPU time, which counts llvmpipe's rasteriser threads;
* the panorama's cost as a ratio to one ``mujoco.Renderer`` render of the same number of output
  pixels (W x H) of the same world from the same poses. The reference is the cheapest single
  render of that scene: one reused Renderer, no MSAA, the camera's visual flags (no shadows,
  reflections or post-processing), light and sky sampling. The out-of-the-box Renderer
  (without MSAA) is shown too;
* the stages of one panorama; the camera options (views, supersampling, views turning with the
  rover instead of looking along compass directions) against the default,
  with a quality figure: the mean absolute difference (grey levels) from an 8-view, 4x
  supersampled panorama of the same pose.

Targets: >= 400 env steps/s per core at 350x40; panorama <= 1.5 x the single render; the
compass views' panorama <= 1.25 x the views turning with the rover (same run).

The machine may be shared: every figure is the median over ``--repeats`` batches, and the
figures that are compared (panorama and its references) are timed in interleaved batches, so
that they see the same load. CPU time counts llvmpipe's worker threads; for figures that do
not depend on them, pass ``--lp-threads 0`` (rasterise in the calling thread).

Backs docs/speed.md.

Usage (from the repository root)::

    .venv/bin/python -m eval.benchmarks.bench_env                  # full tables
    .venv/bin/python -m eval.benchmarks.bench_env --lp-threads 0   # per-core figures, one thread
    .venv/bin/python -m eval.benchmarks.bench_env --quick          # smoke run
    .venv/bin/python -m eval.benchmarks.bench_env --png out/  # also write the panoramas compared
"""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import tyro

from sfa_gym.sim import gl

gl.configure()

import cv2  # noqa: E402
import mujoco  # noqa: E402

from sfa_gym.sim.camera import PanoramaSpec  # noqa: E402
from sfa_gym.sim.camera.renderer import (  # noqa: E402
    OmniCamera,
    headlight_to_eye,
    sample_nearest,
)
from sfa_gym.sim.env import OmniRoverEnv  # noqa: E402

TARGETS = {"ratio_max": 1.5, "steps_per_s_per_core_min": 400.0, "compass_over_rover_max": 1.25}
# Panorama used as ground truth for the quality figure: 8 views, 4x supersampling.
REFERENCE_VIEWS, REFERENCE_SUPERSAMPLE = 8, 4


@dataclass(frozen=True)
class Timing:
    """Median cost of one call: wall and process CPU milliseconds."""

    wall_ms: float
    cpu_ms: float

    @property
    def per_s_per_core(self) -> float:
        return 1000.0 / self.cpu_ms if self.cpu_ms > 0 else float("inf")


def time_interleaved(
    fns: dict[str, Callable[[], object]], n: int = 50, repeats: int = 9
) -> dict[str, Timing]:
    """Median per-call cost of each function over ``repeats`` batches of ``n`` calls.

    The batches of the different functions alternate, so that a load change on a shared
    machine affects them alike (ratios between them stay meaningful).
    """
    for fn in fns.values():
        fn()  # warm-up: GL contexts, shader compilation
    wall: dict[str, list[float]] = {name: [] for name in fns}
    cpu: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(n):
                fn()
            wall[name].append((time.perf_counter() - t0) / n * 1e3)
            cpu[name].append((time.process_time() - c0) / n * 1e3)
    return {
        name: Timing(statistics.median(wall[name]), statistics.median(cpu[name])) for name in fns
    }


# -- scenes -------------------------------------------------------------------------------------


def rover_states(env: OmniRoverEnv, n_poses: int = 8, seed: int = 0) -> list[mujoco.MjData]:
    """Simulation states with the rover resting at ``n_poses`` random poses of the arena."""
    rng = np.random.default_rng(seed)
    xmin, xmax, ymin, ymax = env.arena_bounds
    states = []
    for _ in range(n_poses):
        pose = (rng.uniform(xmin, xmax), rng.uniform(ymin, ymax), rng.uniform(-np.pi, np.pi))
        env.reset(options={"pose": pose})
        data = mujoco.MjData(env.model)
        data.qpos[:] = env.data.qpos
        mujoco.mj_forward(env.model, data)
        states.append(data)
    return states


class Cycle:
    """Calls ``render(state)`` over the states in turn (one call per invocation)."""

    def __init__(self, render: Callable[[mujoco.MjData], object], states: list[mujoco.MjData]):
        self.render, self.states, self.i = render, states, 0

    def __call__(self) -> object:
        self.i = (self.i + 1) % len(self.states)
        return self.render(self.states[self.i])


def single_renderer(camera: OmniCamera, width: int, height: int, *, tuned: bool):
    """A ``mujoco.Renderer`` of ``width`` x ``height`` looking along the rover's heading.

    ``tuned``: the camera's visual flags, light and sky sampling (the cheapest render of the
    same scene); otherwise the Renderer as it comes, without MSAA. Returns ``(render, close)``.
    """
    model = camera.model
    saved = (model.vis.global_.offwidth, model.vis.global_.offheight, model.vis.quality.offsamples)
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    model.vis.quality.offsamples = 0
    try:
        renderer = mujoco.Renderer(model, height, width)
    finally:
        vis = model.vis
        vis.global_.offwidth, vis.global_.offheight, vis.quality.offsamples = saved
    option = mujoco.MjvOption()
    if tuned:
        option.sitegroup[:] = 0
        flags = renderer.scene.flags
        for flag in ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_POST_PROCESSING"):
            flags[getattr(mujoco.mjtRndFlag, flag)] = 0
        renderer._gl_context.make_current()
        sample_nearest(renderer._mjr_context, camera.smooth_skies)
    cam_name = f"{camera.prefix}0"

    def render(data: mujoco.MjData) -> np.ndarray:
        renderer.update_scene(data, camera=cam_name, scene_option=option)
        if tuned:
            headlight_to_eye(renderer.scene)
        return renderer.render()

    return render, renderer.close


# -- camera benchmark ---------------------------------------------------------------------------


def _label(spec: PanoramaSpec) -> str:
    return f"{spec.width}x{spec.height} N={spec.n_views} ss={spec.supersample} {spec.views}"


@dataclass
class CameraRow:
    what: str
    timing: Timing
    ratio: float | None = None  # CPU time / the tuned single render
    ratio_plain: float | None = None  # CPU time / the out-of-the-box single render
    quality: float | None = None  # mean |panorama - reference| in grey levels


def bench_size(
    specs: list[PanoramaSpec],
    n: int,
    repeats: int,
    n_poses: int = 8,
    png_dir: Path | None = None,
    with_before: bool = True,
) -> list[CameraRow]:
    """Panoramas of several specs of one size and their single-render references, interleaved.

    ``with_before``: also time the default spec with the sky sampled as MuJoCo does
    (trilinear), i.e. the camera before the smooth-sky shortcut.
    """
    width, height = specs[0].width, specs[0].height
    reference_spec = replace(specs[0], n_views=REFERENCE_VIEWS, supersample=REFERENCE_SUPERSAMPLE)
    envs, cameras, states, closers = [], {}, {}, []
    fns: dict[str, Callable[[], object]] = {}
    try:
        for spec in [*specs, reference_spec]:
            env = OmniRoverEnv(panorama=spec)
            envs.append(env)
            camera = OmniCamera(env.model, spec)
            closers.append(camera.close)
            cameras[spec] = camera
            states[spec] = rover_states(env, n_poses)
        default = specs[0]
        for tuned, name in ((True, "Renderer WxH"), (False, "Renderer WxH out of the box")):
            render, close = single_renderer(cameras[default], width, height, tuned=tuned)
            closers.append(close)
            fns[name] = Cycle(render, states[default])
        before = OmniCamera(cameras[default].model, default)
        before._smooth_skies = []  # the sky sampled as MuJoCo does (trilinear)
        closers.append(before.close)
        if with_before:
            fns["before"] = Cycle(before.render, states[default])
        for spec in specs:
            fns[_label(spec)] = Cycle(cameras[spec].render, states[spec])
        timings = time_interleaved(fns, n, repeats)

        truth = [
            cameras[reference_spec].render(s).astype(np.float64) for s in states[reference_spec]
        ]
        tuned, plain = timings["Renderer WxH"], timings["Renderer WxH out of the box"]
        rows = [
            CameraRow(f"Renderer {width}x{height} (camera's flags + sky)", tuned),
            CameraRow(f"Renderer {width}x{height} out of the box, no MSAA", plain),
        ]
        panoramas: dict[str, list[np.ndarray]] = {}
        if with_before:
            before_panos = [before.render(s) for s in states[default]]
            panoramas["before"] = before_panos
            rows.append(
                _row(
                    f"panorama {_label(default)} trilinear sky",
                    timings["before"],
                    tuned,
                    plain,
                    before_panos,
                    truth,
                )
            )
        for spec in specs:
            panos = [cameras[spec].render(s) for s in states[spec]]
            panoramas[_label(spec)] = panos
            rows.append(
                _row(f"panorama {_label(spec)}", timings[_label(spec)], tuned, plain, panos, truth)
            )
        if png_dir is not None:
            panoramas[f"reference N={REFERENCE_VIEWS} ss={REFERENCE_SUPERSAMPLE}"] = [
                t.astype(np.uint8) for t in truth
            ]
            _write_pngs(png_dir, f"{width}x{height}", panoramas)
        return rows
    finally:
        for close in closers:
            close()
        for env in envs:
            env.close()


def _row(
    what: str,
    timing: Timing,
    tuned: Timing,
    plain: Timing,
    panos: list[np.ndarray],
    truth: list[np.ndarray],
) -> CameraRow:
    quality = float(np.mean([np.abs(p - t).mean() for p, t in zip(panos, truth, strict=True)]))
    return CameraRow(
        what, timing, timing.cpu_ms / tuned.cpu_ms, timing.cpu_ms / plain.cpu_ms, quality
    )


def _write_pngs(directory: Path, size: str, panoramas: dict[str, list[np.ndarray]]) -> None:
    """One PNG per option: its panoramas of the first three poses, stacked, scaled 3x."""
    directory.mkdir(parents=True, exist_ok=True)
    for name, panos in panoramas.items():
        strip = np.concatenate([np.asarray(p, dtype=np.uint8) for p in panos[:3]], axis=0)
        big = cv2.resize(strip[..., ::-1], None, fx=3, fy=3, interpolation=cv2.INTER_NEAREST)
        safe = "".join(ch if ch.isalnum() else "_" for ch in name)
        cv2.imwrite(str(directory / f"pano_{size}_{safe}.png"), big)


def format_camera_rows(rows: list[CameraRow]) -> str:
    lines = [
        f"{'render (median of batches)':50s} {'wall ms':>8s} {'cpu ms':>7s} {'/s/core':>8s} "
        f"{'x single':>8s} {'x plain':>8s} {'|d| ref':>8s}"
    ]
    for row in rows:
        t = row.timing
        cells = ["" if v is None else f"{v:.2f}" for v in (row.ratio, row.ratio_plain, row.quality)]
        lines.append(
            f"{row.what:50s} {t.wall_ms:8.2f} {t.cpu_ms:7.2f} {t.per_s_per_core:8.0f} "
            f"{cells[0]:>8s} {cells[1]:>8s} {cells[2]:>8s}"
        )
    return "\n".join(lines)


def panorama_stages(spec: PanoramaSpec, n: int, repeats: int) -> dict[str, Timing]:
    """Cost of the stages of one panorama (calls the camera's private stages; keep in step
    with ``sfa_gym/camera.py``).

    llvmpipe rasterises lazily, so the per-view work is split by rendering the same views
    into 8x8 viewports ("draw calls": MuJoCo's and the driver's work per geom, with nothing to
    fill) and at full size ("draw calls + pixels"); both end with ``glFinish``.
    """
    env = OmniRoverEnv(panorama=spec)
    cam = OmniCamera(env.model, spec)
    try:
        states = rover_states(env, 8)
        cam.render(states[0])
        scn, con = cam._scene, cam._con
        cat = mujoco.mjtCatBit.mjCAT_ALL
        pick = Cycle(lambda s: s, states)
        full_rects = cam._rects
        tiny_rects = [mujoco.MjrRect(8 * i, 0, 8, 8) for i in range(len(full_rects))]

        def update() -> mujoco.MjData:
            data = pick()
            mujoco.mjv_updateScene(
                cam.model, data, cam._option, cam._perturb, cam._scene_camera, cat, scn
            )
            cam._headlight_at_eye()
            return data

        def views(rects: list[mujoco.MjrRect]) -> Callable[[], None]:
            def run() -> None:
                cam._rects = rects
                try:
                    data = update()
                    cam._render_views(data, *cam._view_frames(data)[:2])
                    mujoco.mjr_finish()
                finally:
                    cam._rects = full_rects

            return run

        t = time_interleaved(
            {
                "scene update": update,
                "views: draw calls": views(tiny_rects),
                "views: draw calls + pixels": views(full_rects),
                "readPixels": lambda: mujoco.mjr_readPixels(cam._buffer, None, cam._full_rect, con),
                "remap": lambda: cv2.remap(
                    cam._buffer, *cam._remap_maps(0), cv2.INTER_LINEAR, dst=cam._fine
                ),
                "box filter": lambda: cv2.resize(
                    cam._fine, (spec.width, spec.height), interpolation=cv2.INTER_AREA
                ),
                "render() in all": Cycle(cam.render, states),
            },
            n,
            repeats,
        )
    finally:
        cam.close()
        env.close()
    return t


def format_stages(spec: PanoramaSpec, stages: dict[str, Timing]) -> str:
    lines = [f"stages of one panorama {_label(spec)} (cpu ms; views include the scene update):"]
    lines += [f"  {name:22s} {t.cpu_ms:7.3f}" for name, t in stages.items()]
    return "\n".join(lines)


# -- env benchmark ------------------------------------------------------------------------------


def bench_env_steps(
    specs: dict[str, PanoramaSpec], n: int, repeats: int
) -> dict[str, tuple[Timing, Timing]]:
    """Cost of one ``OmniRoverEnv.step`` and of its physics alone, per panorama spec.

    The rover drives a slow circle so that it keeps moving and stays inside the arena.
    """
    envs = {name: OmniRoverEnv(panorama=spec) for name, spec in specs.items()}
    action = np.array([0.3, 0.3], dtype=np.float32)
    fns: dict[str, Callable[[], object]] = {}
    try:
        for name, env in envs.items():
            env.reset(seed=0, options={"pose": (0.0, -1.0, 0.0)})
            fns[name] = lambda env=env: env.step(action)
        some = next(iter(envs.values()))
        fns["physics"] = lambda: mujoco.mj_step(some.model, some.data, nstep=some.frame_skip)
        t = time_interleaved(fns, n, repeats)
    finally:
        for env in envs.values():
            env.close()
    return {name: (t[name], t["physics"]) for name in specs}


def format_env_table(results: dict[str, tuple[Timing, Timing]]) -> str:
    lines = [
        f"{'env step (control period 0.1 s)':42s} {'wall ms':>8s} {'cpu ms':>7s} "
        f"{'steps/s/core':>12s} {'physics ms':>10s}"
    ]
    for name, (step, physics) in results.items():
        lines.append(
            f"{name:42s} {step.wall_ms:8.2f} {step.cpu_ms:7.2f} {step.per_s_per_core:12.0f} "
            f"{physics.cpu_ms:10.2f}"
        )
    return "\n".join(lines)


def camera_specs(width: int, height: int, quick: bool = False) -> list[PanoramaSpec]:
    """The default (first) and the options compared with it."""
    default = PanoramaSpec(width=width, height=height)
    # the views turning with the rover: the camera before the compass views
    rover = replace(default, views="rover")
    if quick:
        return [default, rover, replace(default, supersample=1)]
    return [
        default,
        rover,
        replace(default, n_views=6),
        replace(default, supersample=1),
        replace(default, n_views=6, supersample=1),
        replace(default, n_views=3, supersample=1),
        replace(default, n_views=8, supersample=1),
    ]


@dataclass(frozen=True)
class Args:
    quick: bool = False
    """one size, few calls (smoke run)"""
    n: int = 40
    """calls per timed batch"""
    repeats: int = 9
    """batches; the median counts"""
    lp_threads: int | None = None
    """set LP_NUM_THREADS (llvmpipe rasteriser threads; 0 = the calling thread; None: Mesa's
    default)"""
    png: Path | None = None
    """write the panoramas here (None: nowhere)"""


def main(argv: list[str] | None = None) -> int:
    args = tyro.cli(Args, args=argv, description=__doc__.split("\n\n")[0])
    if args.lp_threads is not None:
        # Read by Mesa when the first GL context is made, which happens below.
        os.environ["LP_NUM_THREADS"] = str(args.lp_threads)
    n, repeats = (5, 3) if args.quick else (args.n, args.repeats)
    print(
        f"GL: {os.environ.get('MUJOCO_GL')}; "
        f"LP_NUM_THREADS={os.environ.get('LP_NUM_THREADS', 'default')}; "
        f"medians of {repeats} interleaved batches of {n} calls; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cpus"
    )
    sizes = [(350, 40)] if args.quick else [(350, 40), (600, 60)]
    checks: dict[str, bool] = {}
    for width, height in sizes:
        specs = camera_specs(width, height, args.quick)
        rows = bench_size(specs, n, repeats, png_dir=args.png)
        print(
            f"\n-- {width}x{height}: |d| ref = mean |panorama - N={REFERENCE_VIEWS} "
            f"ss={REFERENCE_SUPERSAMPLE} panorama| (grey levels) --"
        )
        print(format_camera_rows(rows))
        default = next(r for r in rows if r.what == f"panorama {_label(specs[0])}")
        rover = next(r for r in rows if r.what == f"panorama {_label(specs[1])}")
        over = default.timing.cpu_ms / rover.timing.cpu_ms
        print(f"compass views / views turning with the rover: {over:.2f} x the cpu time")
        checks[f"compass panorama <= 1.25 x rover panorama ({width}x{height})"] = (
            over <= TARGETS["compass_over_rover_max"]
        )
        if (width, height) == (350, 40):
            checks["panorama <= 1.5 x single render (350x40)"] = (
                default.ratio is not None and default.ratio <= TARGETS["ratio_max"]
            )
    spec = PanoramaSpec.paper_sim()
    print()
    print(format_stages(spec, panorama_stages(spec, n, repeats)))
    env_specs = {}
    for width, height in sizes:
        for s in camera_specs(width, height, args.quick)[:4]:
            env_specs[f"step {_label(s)}"] = s
    results = bench_env_steps(env_specs, n, repeats)
    print()
    print(format_env_table(results))
    step = results[f"step {_label(spec)}"][0]
    checks[">= 400 env steps/s per core (350x40)"] = (
        step.per_s_per_core >= TARGETS["steps_per_s_per_core_min"]
    )
    for name, ok in checks.items():
        print(f"target {name}: {'met' if ok else 'NOT met'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
