"""FeatureField: rendered nodes, interpolation, filling around obstacles, the file format and its
errors; with the real env and a really fitted (small) hierarchical SFA."""

from __future__ import annotations

import json
import math
import pickle
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sfa_gym.features import rotation_averaged_features
from sfa_gym.navigation.field import (
    FORMAT,
    FORMAT_VERSION,
    INTERPOLATIONS,
    FeatureField,
    _cell_polynomials,
    world_hash,
)
from sfa_gym.sfa import HierarchicalSFA, RankDeficiencyWarning, presets
from sfa_gym.sim.env import OmniRoverEnv

SPACING = 1.0  # 7 x 7 nodes over the 6 x 6 m arena: cheap to render
MODEL_INFO = {"network": "paper_sim", "dim": 8, "training": "8 x 8 grid"}


@pytest.fixture(autouse=True)
def _quiet_rank_warnings():
    # a small network on 64 locations drops degenerate expanded directions; that is expected
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        yield


@pytest.fixture(scope="module")
def env() -> OmniRoverEnv:
    env = OmniRoverEnv()
    yield env
    env.close()


@pytest.fixture(scope="module")
def model(env) -> HierarchicalSFA:
    """The paper's simulator network, small, fitted on an 8 x 8 grid facing +x."""
    panoramas = np.stack(
        [env.reset(options={"pose": (x, y, 0.0)})[0] for x, y in env.grid_positions(8)]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankDeficiencyWarning)
        sfa = HierarchicalSFA(
            presets.paper_sim(dim=8, out_dim=8), n_outputs=8, weight_sharing="rows", progress=False
        )
        return sfa.fit_rotations(panoramas, step=5)


@pytest.fixture(scope="module")
def field(env, model) -> FeatureField:
    # batch=7: the 49 nodes come in several batches (1, 7, 7, ...)
    return FeatureField.build(
        env, model, spacing=SPACING, batch=7, progress=False, model_info=MODEL_INFO
    )


def _rendered(env, model, x: float, y: float, yaw: float = 0.0) -> np.ndarray:
    panorama = env.reset(options={"pose": (x, y, yaw)})[0]
    return rotation_averaged_features(model, panorama[None], step=1)[0]


# -- the grid and its nodes -------------------------------------------------------------------


def test_grid_covers_the_arena_including_its_edges(env, field):
    xmin, xmax, ymin, ymax = env.arena_bounds
    assert field.values.shape == (7, 7, 8)
    np.testing.assert_allclose(field.xs, np.linspace(xmin, xmax, 7))
    np.testing.assert_allclose(field.ys, np.linspace(ymin, ymax, 7))
    assert field.spacing == pytest.approx((SPACING, SPACING))
    assert field.free.all()


def test_spacing_that_does_not_divide_the_arena_is_rounded_down(env, model):
    field = FeatureField.build(env, model, spacing=1.4, progress=False)
    xmin, xmax, ymin, ymax = env.arena_bounds
    # ceil(6 / 1.4) = 5 cells: 6 nodes 1.2 m apart, the edges included
    assert field.values.shape[:2] == (6, 6)
    assert field.spacing == pytest.approx((1.2, 1.2))
    assert (field.xs[0], field.xs[-1], field.ys[0], field.ys[-1]) == (xmin, xmax, ymin, ymax)
    assert field.metadata["spacing"] == 1.4
    assert field.metadata["node_spacing"] == pytest.approx([1.2, 1.2])


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_values_at_the_nodes_are_the_rendered_features(env, model, field, interpolation):
    f = field.with_interpolation(interpolation)
    # nodes off the diagonal (x != y) catch a swapped axis; corners and edges the clamping
    for i, j in [(0, 0), (6, 6), (1, 4), (5, 2), (0, 6), (3, 0)]:
        x, y = float(f.xs[i]), float(f.ys[j])
        expected = _rendered(env, model, x, y)
        # the field transforms the nodes in batches of 7, this one alone: BLAS may sum the same
        # products in another order, so the last bits can differ (seen: 1e-7 relative)
        np.testing.assert_allclose(f.values[j, i], expected, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(f.at(x, y), expected, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(f(np.array([[x, y]]))[0], expected, rtol=1e-6, atol=1e-6)
    points = np.stack(np.meshgrid(f.xs, f.ys), axis=-1).reshape(-1, 2)
    np.testing.assert_allclose(f(points), f.values.reshape(-1, 8), rtol=1e-6, atol=1e-6)


def test_whole_column_turns_do_not_change_the_features(env, model, field):
    """Why the field may ignore the heading: with the compass camera a turn by whole columns
    shifts the panorama exactly, and the average over every column does not see the shift."""
    x, y = float(field.xs[2]), float(field.ys[4])
    for k in (1, 37, 175):
        turned = _rendered(env, model, x, y, yaw=2 * math.pi * k / 350)
        np.testing.assert_allclose(turned, field.values[4, 2], atol=1e-5)


def test_metadata_describes_world_camera_and_model(env, field):
    meta = field.metadata
    assert meta["world"] == "paper_sim"
    assert meta["world_hash"] == world_hash(env.world_spec)
    assert meta["world_hash"].startswith("sha256:")
    assert world_hash(replace(env.world_spec, description="another")) != meta["world_hash"]
    assert meta["world_seed"] == 0
    assert (meta["panorama_height"], meta["panorama_width"]) == (40, 350)
    assert meta["panorama"]["views"] == "compass"
    assert (meta["spacing"], meta["step"], meta["n_features"]) == (SPACING, 1, 8)
    assert meta["heading"] == 0.0
    assert meta["model_info"] == MODEL_INFO
    assert meta["model"] == "HierarchicalSFA"
    assert isinstance(meta["sfa_gym_version"], str)
    field.check_env(env)
    other = FeatureField(field.values, field.bounds, metadata={**meta, "world_seed": 3})
    with pytest.raises(ValueError, match="world_seed is 0, the field's 3"):
        other.check_env(env)


def test_a_field_file_without_its_world_is_refused_by_an_env(env, field, tmp_path):
    stripped = {k: v for k, v in field.metadata.items() if k not in ("world", "world_hash")}
    FeatureField(field.values, field.bounds, metadata=stripped).check_env(env)  # built here
    FeatureField(field.values, field.bounds, metadata=stripped).save(tmp_path / "f.npz")
    with pytest.raises(ValueError, match=r"does not say which world.*\['world', 'world_hash'\]"):
        FeatureField.load(tmp_path / "f.npz").check_env(env)
    nulled = {**field.metadata, "world_hash": None}  # the keys kept, their values wiped
    FeatureField(field.values, field.bounds, metadata=nulled).save(tmp_path / "g.npz")
    with pytest.raises(ValueError, match="world_hash is 'sha256:"):
        FeatureField.load(tmp_path / "g.npz").check_env(env)
    field.save(tmp_path / "h.npz")
    FeatureField.load(tmp_path / "h.npz").check_env(env)  # a whole file passes


# -- interpolation -----------------------------------------------------------------------------


def test_linear_midpoints_are_the_mean_of_the_neighbours(field):
    f = field.with_interpolation("linear")
    v, xs, ys = f.values, f.xs, f.ys
    np.testing.assert_allclose(f.at((xs[1] + xs[2]) / 2, ys[3]), (v[3, 1] + v[3, 2]) / 2, 1e-6)
    np.testing.assert_allclose(f.at(xs[4], (ys[0] + ys[1]) / 2), (v[0, 4] + v[1, 4]) / 2, 1e-6)
    centre = f.at((xs[2] + xs[3]) / 2, (ys[5] + ys[6]) / 2)
    np.testing.assert_allclose(centre, v[5:7, 2:4].mean(axis=(0, 1)), rtol=1e-6, atol=1e-6)


def test_catmull_rom_midpoints_stay_near_the_neighbours(field):
    """At a cell's centre Catmull-Rom weighs the 4 x 4 nodes around it with the outer product
    of (-1, 9, 9, -1) / 16; it differs from the bilinear mean of the 4 corners by at most
    0.5625 x half the spread of those 16 nodes."""
    f = field.with_interpolation("catmull-rom")
    v = f.values
    for i in range(1, 5):
        for j in range(1, 5):
            centre = f.at((f.xs[i] + f.xs[i + 1]) / 2, (f.ys[j] + f.ys[j + 1]) / 2)
            near = v[j - 1 : j + 3, i - 1 : i + 3].reshape(-1, 8)
            spread = near.max(axis=0) - near.min(axis=0)
            linear = v[j : j + 2, i : i + 2].mean(axis=(0, 1))
            assert np.all(np.abs(centre - linear) <= 0.5625 * spread / 2 + 1e-5)
            w = np.array([-1, 9, 9, -1]) / 16
            expected = np.einsum("a,b,abk->k", w, w, v[j - 1 : j + 3, i - 1 : i + 3])
            np.testing.assert_allclose(centre, expected, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_interpolation_is_continuous_across_cell_borders(field, interpolation):
    f = field.with_interpolation(interpolation)
    eps = 1e-7
    for b in f.xs[1:-1]:
        y = 0.37
        left, right = f.at(b - eps, y), f.at(b + eps, y)
        np.testing.assert_allclose(left, right, atol=1e-4)
    for b in f.ys[1:-1]:
        x = -1.21
        np.testing.assert_allclose(f.at(x, b - eps), f.at(x, b + eps), atol=1e-4)
    if interpolation != "linear":
        # and so is the slope: one-sided differences over 1 mm either side of a border agree
        h, b, y = 1e-3, float(f.xs[3]), 0.37
        slope_left = (f.at(b, y).astype(np.float64) - f.at(b - h, y)) / h
        slope_right = (f.at(b + h, y).astype(np.float64) - f.at(b, y)) / h
        scale = np.abs(f.values).max() / f.spacing[0]
        assert np.abs(slope_left - slope_right).max() < 0.05 * scale


def _polynomial_field(interpolation: str, fn) -> tuple[FeatureField, object]:
    xs, ys = np.linspace(-1.0, 2.0, 7), np.linspace(0.0, 1.0, 5)
    gx, gy = np.meshgrid(xs, ys)
    return FeatureField(fn(gx, gy), (-1.0, 2.0, 0.0, 1.0), interpolation=interpolation), fn


@pytest.mark.parametrize(
    ("interpolation", "fn"),
    [
        *[
            (i, lambda x, y: np.stack([1 + 2 * x - y + 0.5 * x * y, x * y], -1))
            for i in INTERPOLATIONS
        ],
        ("cubic", lambda x, y: np.stack([x**3 - 2 * x * y**2 + y**3, x**2 * y**3], axis=-1)),
    ],
)
def test_interpolation_reproduces_polynomials_of_its_degree(interpolation, fn):
    """Known answer: every method reproduces bilinear functions, the cubic spline bicubic ones
    (Catmull-Rom reproduces quadratics only away from the edges, where a node is missing)."""
    field, fn = _polynomial_field(interpolation, fn)
    points = np.random.default_rng(0).uniform((-1.0, 0.0), (2.0, 1.0), (200, 2))
    expected = fn(points[:, 0], points[:, 1])
    np.testing.assert_allclose(field(points), expected, rtol=1e-5, atol=1e-5)
    single = np.stack([field.at(x, y) for x, y in points])
    np.testing.assert_array_equal(single, field(points))


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
@pytest.mark.parametrize("k", [1, 3, 65])
def test_the_table_built_block_by_block_is_the_whole_tables_bits(interpolation, k):
    """A table filled one cell row at a time holds the same bits as one filled at once (same
    numbers on every field, whatever its block size)."""
    rng = np.random.default_rng(k)
    values = rng.normal(size=(9, 7, k)) * 10.0 ** rng.uniform(-3, 3, size=k)
    xs, ys = np.linspace(0.0, 3.0, 7), np.linspace(-1.0, 2.0, 9)
    whole = _cell_polynomials(values, xs, ys, interpolation, block_bytes=2**40)
    # one cell row per block; three rows (of 6 cells) per block, the last block two rows
    for block_bytes in (1, 3 * whole[0].nbytes * 6):
        rows = _cell_polynomials(values, xs, ys, interpolation, block_bytes=block_bytes)
        assert rows.shape == whole.shape
        np.testing.assert_array_equal(rows.view(np.uint64), whole.view(np.uint64))


def test_a_fields_table_costs_its_own_size_and_one_block():
    """Building a field's table of many features holds the table and a block of cell rows, not
    the table's intermediate copies (four of them before)."""
    import tracemalloc

    values = np.random.default_rng(0).normal(size=(41, 31, 64))
    xs, ys = np.linspace(0.0, 3.0, 31), np.linspace(0.0, 4.0, 41)
    _cell_polynomials(values[:2, :2, :1], xs[:2], ys[:2], "catmull-rom")  # imports first
    tracemalloc.start()
    try:  # a 9.4 MiB table in 36 blocks
        table = _cell_polynomials(values, xs, ys, "catmull-rom", block_bytes=2**18)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert table.nbytes == 40 * 30 * 16 * 64 * 8
    assert peak < 1.5 * table.nbytes, (
        f"peak {peak / 2**20:.1f} MiB for a {table.nbytes / 2**20:.1f} MiB table"
    )


def test_catmull_rom_reproduces_quadratics_away_from_the_edges():
    field, fn = _polynomial_field(
        "catmull-rom", lambda x, y: np.stack([x**2 * y**2 - 3 * x * y + y**2, x**2], axis=-1)
    )
    xs, ys = field.xs, field.ys
    points = np.random.default_rng(2).uniform((xs[1], ys[1]), (xs[-2], ys[-2]), (100, 2))
    np.testing.assert_allclose(field(points), fn(points[:, 0], points[:, 1]), atol=1e-5)


def test_points_outside_the_grid_are_clamped(field):
    inside = np.array([[-3.0, 1.2], [3.0, -3.0], [0.4, 3.0]])
    outside = np.array([[-7.0, 1.2], [3.5, -30.0], [0.4, 3.01]])
    np.testing.assert_array_equal(field(outside), field(inside))
    assert field(np.array([0.1, 0.2])).shape == (8,)
    assert field(np.zeros((0, 2))).shape == (0, 8)
    assert field(inside).dtype == np.float32


@pytest.mark.parametrize(
    ("points", "match"),
    [(np.zeros((3, 3)), r"shape \(n, 2\)"), (np.array([[0.0, np.nan]] * 2), "finite")],
)
def test_bad_points_are_refused(field, points, match):
    with pytest.raises(ValueError, match=match):
        field(points)
    with pytest.raises(ValueError, match="finite"):
        field.at(math.inf, 0.0)


# -- obstacles ---------------------------------------------------------------------------------


def test_nodes_inside_obstacles_are_filled_from_the_nearest_free_node(env, model, monkeypatch):
    def free(points: np.ndarray) -> np.ndarray:
        return np.hypot(points[:, 0] - 1.0, points[:, 1]) > 1.2  # a disc at (1, 0)

    rendered = []
    reset = env.reset

    def counting_reset(**kwargs):
        rendered.append(kwargs["options"]["pose"][:2])
        return reset(**kwargs)

    monkeypatch.setattr(env, "reset", counting_reset)
    field = FeatureField.build(env, model, spacing=SPACING, free=free, progress=False)
    nodes = np.stack(np.meshgrid(field.xs, field.ys), axis=-1)
    mask = free(nodes.reshape(-1, 2)).reshape(7, 7)
    assert (~mask).sum() == 5
    np.testing.assert_array_equal(field.free, mask)
    assert len(rendered) == mask.sum()  # the non-free nodes were never rendered
    assert not any(np.hypot(x - 1.0, y) <= 1.2 for x, y in rendered)
    free_nodes = nodes[mask]
    for j, i in zip(*np.nonzero(~mask), strict=True):
        distance = np.hypot(*(free_nodes - nodes[j, i]).T)
        nearest = free_nodes[np.isclose(distance, distance.min())]
        sources = [field.values[np.argmin(np.abs(field.ys - y)), np.argmin(np.abs(field.xs - x))]
                   for x, y in nearest]  # fmt: skip
        assert any(np.array_equal(field.values[j, i], s) for s in sources)
    assert field.metadata["n_free"] == 44


# -- bad arguments -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"spacing": 0}, ValueError, "spacing must be a positive finite number.*0.0"),
        ({"spacing": -0.5}, ValueError, r"spacing must be .*-0\.5"),
        ({"spacing": math.nan}, ValueError, "spacing must be .*nan"),
        ({"spacing": 6.5}, ValueError, r"spacing 6\.5 m is larger than the arena \(6 x 6 m\)"),
        ({"spacing": "0.1"}, TypeError, "spacing must be a number.*'0.1'"),
        ({"step": 0}, ValueError, "step must be a positive int, got 0"),
        ({"step": 3}, ValueError, "step 3 does not divide the panorama width 350"),
        ({"batch": 0}, ValueError, "batch must be a positive int, got 0"),
        ({"interpolation": "nearest"}, ValueError, "interpolation must be one of.*'nearest'"),
        ({"free": lambda p: np.ones(3, bool)}, ValueError, r"got shape \(3,\)"),
        ({"free": lambda p: np.zeros(len(p), bool)}, ValueError, "none of the 49 grid nodes"),
    ],
)
def test_bad_arguments_are_refused(env, model, kwargs, error, match):
    with pytest.raises(error, match=match):
        FeatureField.build(env, model, **{"spacing": SPACING, "progress": False, **kwargs})


def test_wrong_models_are_refused(env):
    with pytest.raises(TypeError, match="model must be a fitted feature model.*object"):
        FeatureField.build(env, object(), spacing=SPACING, progress=False)
    unfitted = HierarchicalSFA(presets.paper_sim(dim=8, out_dim=8), progress=False)
    with pytest.raises(ValueError, match="model HierarchicalSFA cannot compute features"):
        FeatureField.build(env, unfitted, spacing=SPACING, progress=False)
    small = np.random.default_rng(0).integers(0, 256, (6, 10, 40, 3), dtype=np.uint8)
    other = HierarchicalSFA(presets.tiny(10, 40), n_outputs=4, progress=False)
    other.fit_rotations(small, step=8)
    with pytest.raises(ValueError, match=r"cannot compute features .*\(40, 350, 3\)"):
        FeatureField.build(env, other, spacing=SPACING, progress=False)


def test_bad_values_are_refused():
    with pytest.raises(ValueError, match=r"values must be \(ny, nx, k\).*\(3, 4\)"):
        FeatureField(np.zeros((3, 4)), (0, 1, 0, 1))
    with pytest.raises(ValueError, match="finite"):
        FeatureField(np.full((2, 2, 1), np.nan), (0, 1, 0, 1))
    too_large = "magnitude of 1e\\+300; features must stay within 1e\\+12"
    with pytest.raises(ValueError, match=too_large):
        FeatureField(np.full((2, 2, 1), 1e300), (0, 1, 0, 1))
    with pytest.raises(ValueError, match="xmin < xmax"):
        FeatureField(np.zeros((2, 2, 1)), (1, 0, 0, 1))


# -- files -------------------------------------------------------------------------------------


@pytest.mark.parametrize("interpolation", INTERPOLATIONS)
def test_save_load_round_trip(field, tmp_path, interpolation):
    original = field.with_interpolation(interpolation)
    path = tmp_path / "field.npz"
    original.save(path)
    loaded = FeatureField.load(path)
    np.testing.assert_array_equal(loaded.values, original.values)
    np.testing.assert_array_equal(loaded.free, original.free)
    assert loaded.bounds == original.bounds
    assert loaded.metadata == original.metadata
    assert loaded.interpolation == interpolation
    points = np.random.default_rng(1).uniform(-3.2, 3.2, (50, 2))
    np.testing.assert_array_equal(loaded(points), original(points))
    assert FeatureField.load(path, interpolation="linear").interpolation == "linear"
    with np.load(path, allow_pickle=False) as archive:
        header = json.loads(str(archive["header"]))
        assert sorted(archive.files) == ["free", "header", "values"]
    assert (header["format"], header["version"]) == (FORMAT, FORMAT_VERSION)
    assert header["shape"] == [7, 7, 8]


def _write(path: Path, json_header: dict | None, **arrays) -> Path:
    if json_header is not None:
        arrays["header"] = np.array(json.dumps(json_header))
    np.savez(path, **arrays)
    return path


@pytest.fixture
def good(field) -> dict:
    return {"header": field.header(), "values": field.values, "free": field.free}


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda g: g["header"].update(version=2), "format version 2 is newer"),
        (lambda g: g["header"].update(version="1"), "invalid format version '1'"),
        (lambda g: g["header"].update(format="sfa-gym-model"), "format is 'sfa-gym-model'"),
        (lambda g: g["header"].pop("shape"), r"the header lacks \['shape'\]"),
        (lambda g: g.pop("free"), r"missing member\(s\) \['free'\]"),
        (lambda g: g.pop("header"), r"missing member\(s\) \['header'\]"),
        (lambda g: g.update(extra=np.zeros(2)), r"members the format does not define: \['extra'"),
        (lambda g: g.update(values=g["values"][:, :5]), "member 'values' has shape"),
        (lambda g: g.update(values=g["values"].astype(np.float32)), "dtype float32"),
        (
            lambda g: g.update(free=np.array([{"a": 1}], dtype=object)),
            "member 'free' holds Python objects",
        ),
        (lambda g: g.update(header={"x": [1, 2]}), "format is None"),
    ],
)
def test_load_refuses_bad_files(tmp_path, good, change, match):
    change(good)
    header = good.pop("header", None)
    path = _write(tmp_path / "bad.npz", header, **good)
    with pytest.raises(ValueError, match=match) as info:
        FeatureField.load(path)
    assert str(path) in str(info.value)


def test_load_refuses_pickles_and_foreign_files(tmp_path):
    pickled = tmp_path / "field.pkl"
    pickled.write_bytes(pickle.dumps({"values": np.zeros((2, 2, 1))}))
    with pytest.raises(ValueError, match="is a pickle") as info:
        FeatureField.load(pickled)
    assert str(pickled) in str(info.value)
    text = tmp_path / "field.txt"
    text.write_text("not a field")
    with pytest.raises(ValueError, match="not a readable .npz archive"):
        FeatureField.load(text)
    object_header = _write(
        tmp_path / "obj.npz",
        None,
        header=np.array({"a": 1}, dtype=object),
        values=np.zeros((2, 2, 1)),
        free=np.ones((2, 2), bool),
    )
    with pytest.raises(ValueError, match="member 'header' holds Python objects"):
        FeatureField.load(object_header)
    with pytest.raises(FileNotFoundError, match="no feature field file"):
        FeatureField.load(tmp_path / "missing.npz")


def test_save_refuses_metadata_that_json_cannot_hold(field, tmp_path):
    bad = FeatureField(field.values, field.bounds, metadata={"model_info": {"x": math.nan}})
    with pytest.raises(ValueError, match=r"model_info\.x = nan"):
        bad.save(tmp_path / "f.npz")
    odd = FeatureField(field.values, field.bounds, metadata={"model": object()})
    with pytest.raises(ValueError, match="not JSON-serialisable"):
        odd.save(tmp_path / "f.npz")
    assert not list(tmp_path.iterdir())  # nothing half-written


def test_a_rotation_invariant_method_is_averaged_with_one_transform_per_panorama():
    """Band means (a column statistic) declare rotation_invariant: their rotation average is
    their features of the panorama itself, computed once instead of once per column."""
    from sfa_gym.plugins import load_method

    rng = np.random.default_rng(3)
    panoramas = rng.integers(0, 256, size=(3, 12, 40, 3), dtype=np.uint8)
    method = load_method("band_means", {"n_bands": 4}).fit(panoramas)
    calls = []
    transform = method.transform
    method.transform = lambda views: calls.append(len(views)) or transform(views)
    fast = rotation_averaged_features(method, panoramas, step=1)
    assert calls == [3]  # one call, one view per panorama
    every_column = np.stack(
        [transform(np.roll(panoramas, -k, axis=2)) for k in range(panoramas.shape[2])]
    ).mean(axis=0)
    np.testing.assert_allclose(fast, every_column, rtol=1e-12)
