"""Packaging, headless GL selection and small library utilities."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from sfa_gym.recording.ordering import edge_walk, grid_order, hilbert_index
from sfa_gym.sim import gl

ROOT = Path(__file__).resolve().parents[1]


def test_wheel_ships_world_data_and_no_generic_top_level_modules(tmp_path):
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(ROOT)],
        check=True,
    )
    (wheel,) = tmp_path.glob("sfa_gym-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    top_level = {name.split("/")[0] for name in names}
    checkout_only = {"envs", "baselines", "tests", "eval", "tracks", "published"}
    assert not top_level & checkout_only, top_level
    assert "sfa_gym/envs_data/paper_sim.json" in names
    assert "sfa_gym/tracks_data/train_test.json" in names
    # the reference board that `sfa-gym leaderboard table` shows beside a user's results
    assert "sfa_gym/published_data/leaderboard/quick.json" in names
    assert "sfa_gym/py.typed" in names


def test_gl_error_names_the_debian_packages(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.setattr(gl, "_loads", lambda names: False)
    with pytest.raises(gl.HeadlessGLError, match="libegl1.*libosmesa6"):
        gl.configure()


def test_gl_falls_back_to_osmesa_when_egl_is_missing(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    # configure() sets PYOPENGL_PLATFORM for OSMesa: restore it afterwards, or every later
    # context in this process would mix OSMesa's PyOpenGL with the EGL backend and crash
    monkeypatch.delenv("PYOPENGL_PLATFORM", raising=False)
    monkeypatch.setattr(gl, "_loads", lambda names: names[0] == "OSMesa")
    assert gl.configure() == "osmesa"


def test_gl_respects_the_users_choice(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    assert gl.configure() == "egl"


@pytest.mark.parametrize("order", [1, 3, 5])
def test_hilbert_curve_visits_every_cell_once_in_unit_steps(order):
    n = 1 << order
    rows, cols = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    cells = np.stack([rows.ravel(), cols.ravel()], axis=1)
    assert sorted(hilbert_index(cells[:, 0], cells[:, 1], order)) == list(range(n * n))
    path = cells[grid_order(cells)]
    assert np.abs(np.diff(path, axis=0)).sum(axis=1).max() == 1


def test_serpentine_alternates_direction():
    rows, cols = np.meshgrid(np.arange(3), np.arange(4), indexing="ij")
    cells = np.stack([rows.ravel(), cols.ravel()], axis=1)
    path = cells[grid_order(cells, kind="serpentine")]
    assert path[:5].tolist() == [[0, 0], [0, 1], [0, 2], [0, 3], [1, 3]]


def test_edge_walk_steps_along_every_edge_once_each_way_and_never_across_a_hole():
    # a 5 x 5 grid with a wall of three cells in the middle row, one isolated cell apart
    rows, cols = np.meshgrid(np.arange(5), np.arange(5), indexing="ij")
    cells = np.stack([rows.ravel(), cols.ravel()], axis=1)
    cells = cells[~((cells[:, 0] == 2) & (cells[:, 1] >= 1) & (cells[:, 1] <= 3))]
    cells = np.vstack([cells, [[9, 9]]])
    walk = edge_walk(cells)
    path = cells[walk]
    assert np.abs(np.diff(path, axis=0)).sum(axis=1).tolist() == [1] * (len(walk) - 1)
    steps = sorted(zip(walk[:-1].tolist(), walk[1:].tolist(), strict=True))
    edges = {
        (a, b)
        for a in range(len(cells))
        for b in range(len(cells))
        if np.abs(cells[a] - cells[b]).sum() == 1
    }
    assert steps == sorted(edges)  # every directed step once: 30 edges, both ways
    assert walk[0] == walk[-1] == 0 and len(cells) - 1 not in walk  # the isolated cell is left
    # a cell that forbids its step towards +i loses that edge, both ways
    passable = np.ones((len(cells), 4), dtype=bool)
    passable[0, 0] = False
    assert len(edge_walk(cells, passable)) == len(walk) - 2
    with pytest.raises(ValueError, match="distinct"):
        edge_walk(np.zeros((2, 2), dtype=int))
    with pytest.raises(ValueError, match=r"passable must have shape \(3, 4\)"):
        edge_walk(cells[:3], np.ones((3, 3), dtype=bool))


def test_grid_order_rejects_bad_input():
    with pytest.raises(ValueError, match="kind"):
        grid_order(np.zeros((3, 2), dtype=int), kind="zigzag")
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        grid_order(np.zeros((3, 3), dtype=int))


def test_sfa_engine_imports_neither_gymnasium_nor_mujoco():
    import ast

    for path in sorted((ROOT / "sfa_gym" / "sfa").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            for name in names:
                root = name.split(".")[0]
                assert root not in {"gymnasium", "mujoco"}, f"{path.name} imports {name}"
                # the engine may use the numpy-only helpers of the package, nothing of the sim
                assert not name.startswith("sfa_gym.") or name.startswith(
                    (
                        "sfa_gym.sfa",
                        "sfa_gym._types",
                        "sfa_gym._checks",
                        "sfa_gym.rotation",
                        "sfa_gym.files",
                        "sfa_gym.capabilities",  # the declaration of what a model can do
                    )
                ), f"{path.name} imports {name}"


def test_importing_the_sfa_engine_loads_neither_mujoco_nor_opengl():
    code = (
        "import sys, sfa_gym.sfa; "
        "print(sorted(m for m in ('mujoco', 'OpenGL') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout
