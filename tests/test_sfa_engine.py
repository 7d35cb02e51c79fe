"""Engine internals: moments of quadratic expansions, of consecutive frames and of periodic node
inputs, BLAS threads, the ordered thread map."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from sfa_gym.sfa import _parallel
from sfa_gym.sfa._fourth import QuadraticGram, pair_groups
from sfa_gym.sfa._layers import extract_patches
from sfa_gym.sfa._moments import Moments, difference_basis, sequence_block
from sfa_gym.sfa._periodic import plan_weighted_gram, smallest_period
from sfa_gym.sfa.expansion import n_quadratic_features, quadratic_expand


@pytest.mark.parametrize("k", [1, 2, 5, 9, 32])
def test_pair_groups_cover_every_second_index_once(k):
    groups = pair_groups(k)
    assert groups[0][0] == 0 and groups[-1][1] == k
    assert all(a[1] == b[0] and a[0] < a[1] for a, b in zip(groups, groups[1:], strict=False))


@pytest.mark.parametrize("k", [1, 2, 3, 7, 12])
def test_quadratic_gram_equals_the_direct_gram_of_the_expansion(k):
    rng = np.random.default_rng(k)
    y = rng.standard_normal((k, 300))
    q = quadratic_expand(y, axis=0)
    plan = QuadraticGram(k)
    assert plan.n_features == n_quadratic_features(k)
    for w in (None, rng.integers(0, 4, 300).astype(np.float64)):
        got = plan.assemble([p.ravel() for p in plan.products(q, w)])
        want = (q if w is None else q * w) @ q.T
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_quadratic_moments_equal_plain_moments_over_chunks():
    rng = np.random.default_rng(0)
    k = 6
    e = n_quadratic_features(k)
    fast, plain = Moments(e, center=False, quadratic=k), Moments(e, center=False)
    for i, weighted in enumerate((False, True, True)):
        q = quadratic_expand(rng.standard_normal((k, 200)) + i, axis=0)
        w = rng.integers(1, 3, 200).astype(np.float64) if weighted else None
        if i == 2:
            w = np.full(200, 3.0)  # one count for all rows takes the scaled path
        t = np.arange(200.0) + 200 * i
        for m in (fast, plain):
            m.add_samples(q[None], t * (1 if w is None else w), w)
            m.add_differences(np.diff(q, axis=1)[None])
    a, b = fast.finish(), plain.finish()
    for name in ("mean", "cov", "dcov", "cov_xt"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-11, atol=1e-11)
    with pytest.raises(ValueError, match="quadratic expansion"):
        Moments(e + 1, center=False, quadratic=k)


@pytest.mark.parametrize("k", [1, 2, 5, 16])
def test_difference_basis_diagonalises_the_path_laplacian(k):
    basis, lam = difference_basis(k)
    d = np.diff(np.eye(k), axis=0)  # (k - 1, k) first differences
    np.testing.assert_allclose(basis.T @ basis, np.eye(k), atol=1e-12)
    np.testing.assert_allclose(basis.T @ (d.T @ d) @ basis, np.diag(lam), atol=1e-12)
    assert lam[0] == 0 and np.all(np.diff(lam) > 0)


def test_sequence_blocks_keep_enough_samples_per_product():
    assert sequence_block(56, 490) == 14  # 4 blocks, no frame left over
    assert sequence_block(56, 42) == 8  # 7 blocks of 42 positions: 294 samples per product
    assert sequence_block(56, 7) == 1  # too few samples per product: no blocks
    assert sequence_block(1, 490) == 1


@pytest.mark.parametrize("center", [True, False])
@pytest.mark.parametrize("samples_first", [True, False])
@pytest.mark.parametrize("n", [1, 2, 3, 17, 40, 61])
def test_sequence_moments_equal_samples_plus_differences(center, samples_first, n):
    """One Gram matrix per basis vector gives the same statistics as the samples and their
    differences apart, for any number of frames (whole blocks, frames left over, no block)."""
    rng = np.random.default_rng(n)
    p, f = 40, 6
    x = 50 + rng.standard_normal((n, p, f)).cumsum(axis=0)  # slow, far from zero mean
    frames_last = x.transpose(2, 0, 1)  # (F, n, P)
    want = Moments(f, center=center)
    want.add_samples(frames_last.reshape(f, -1)[None], np.repeat(7.0 + np.arange(n), p))
    want.add_differences(np.diff(frames_last, axis=1).reshape(f, -1)[None])
    for overwrite in (False, True):
        data = x.copy() if samples_first else np.ascontiguousarray(frames_last)
        before = data.copy()
        got = Moments(f, center=center)
        got.add_sequence(data, 7.0, samples_first, overwrite=overwrite)
        if not overwrite:
            np.testing.assert_array_equal(data, before)
        a, b = got.finish(), want.finish()
        for name in ("mean", "cov", "dcov", "cov_xt"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-9, atol=1e-9)
        assert (a.n_samples, a.n_differences, a.var_t) == (b.n_samples, b.n_differences, b.var_t)


def test_sequence_moments_in_float32_keep_slow_differences_precise():
    """Slow features far from zero: the basis change works on differences from each block's
    first frame, so the difference moments keep the precision of float32 differences: 2e-7
    here, like the differences formed directly, where a basis change of the raw values errs by
    3e-4 (cancellation)."""
    rng = np.random.default_rng(3)
    n, p, f = 64, 64, 4
    x = (100 + 1e-3 * rng.standard_normal((n, p, f)).cumsum(axis=0)).astype(np.float32)
    exact = Moments(f, center=False)
    exact.add_sequence(x.astype(np.float64), 0.0, True)
    fast = Moments(f, center=False)
    fast.add_sequence(x, 0.0, True)
    want, got = exact.finish().dcov, fast.finish().dcov
    assert np.abs(got - want).max() <= 1e-5 * np.abs(want).max()


def test_sequence_moments_reject_other_accumulators():
    with pytest.raises(ValueError, match="one group"):
        Moments(3, n_groups=2).add_sequence(np.zeros((4, 5, 3)), 0.0, True)
    with pytest.raises(ValueError, match="expected 3 features"):
        Moments(3).add_sequence(np.zeros((4, 5, 2)), 0.0, True)


def test_partial_statistics_merge_to_the_serial_result():
    rng = np.random.default_rng(1)
    chunks = [rng.standard_normal((1, 5, 40)) + 100 for _ in range(3)]
    serial = Moments(5)
    for i, x in enumerate(chunks):
        serial.add_samples(x, np.arange(40.0) + 40 * i)
    merged = Moments(5)
    merged.add_samples(chunks[0], np.arange(40.0))
    for i, x in enumerate(chunks[1:], start=1):
        part = merged.partial()
        part.add_samples(x, np.arange(40.0) + 40 * i)
        merged.merge(part)
    np.testing.assert_array_equal(serial.finish().cov, merged.finish().cov)
    with pytest.raises(ValueError, match="origin"):
        Moments(5).partial()
    with pytest.raises(ValueError, match="same origin"):
        merged.merge(serial)


def _blas_threads() -> list[int]:
    """Thread counts of the engine's BLAS libraries (numpy's and scipy's; not one another
    package loads later), as a fresh threadpoolctl scan sees them."""
    engine = {lib["filepath"] for lib in _parallel._blas().info()}
    return [lib["num_threads"] for lib in threadpool_info() if lib["filepath"] in engine]


def _two_blas_threads() -> list[int]:
    """The thread counts under ``threadpool_limits(2)``; skips where BLAS caps them lower (one
    CPU), since the tests could then not tell a limit from no limit."""
    before = _blas_threads()
    if not before or any(n != 2 for n in before):
        pytest.skip(f"BLAS runs {before} threads when asked for 2")
    return before


@pytest.mark.skipif(not _parallel.blas_controllable(), reason="no BLAS threadpoolctl can control")
def test_single_threaded_blas_is_scoped_and_nestable():
    with threadpool_limits(limits=2, user_api="blas"):
        before = _two_blas_threads()
        with _parallel.single_threaded_blas():
            assert _blas_threads() == [1] * len(before)
            with _parallel.single_threaded_blas():
                assert _blas_threads() == [1] * len(before)
        assert _blas_threads() == before


@pytest.mark.skipif(not _parallel.blas_controllable(), reason="no BLAS threadpoolctl can control")
def test_single_threaded_blas_works_from_any_thread():
    # OpenBLAS's thread count is process-wide. The block limits it from a thread other than the
    # one holding a threadpoolctl limit, and a thread leaving its block does not restore the
    # count while another thread is still inside one.
    entered, left = threading.Event(), threading.Event()
    seen: list[list[int]] = []

    def alone() -> None:
        with _parallel.single_threaded_blas():
            seen.append(_blas_threads())

    def overlapping() -> None:
        with _parallel.single_threaded_blas():
            entered.set()
            left.wait(5)
            seen.append(_blas_threads())

    with threadpool_limits(limits=2, user_api="blas"):
        before = _two_blas_threads()
        one = [1] * len(before)
        worker = threading.Thread(target=alone)
        worker.start()
        worker.join(5)
        assert seen == [one] and _blas_threads() == before
        worker = threading.Thread(target=overlapping)
        with _parallel.single_threaded_blas():
            worker.start()
            entered.wait(5)
        left.set()  # the main thread has left; the other is still inside
        worker.join(5)
        assert seen == [one, one]
        assert _blas_threads() == before


def test_ordered_map_keeps_the_order_and_raises_errors():
    def slow_square(i: int) -> tuple[int, str]:
        time.sleep(0.002 * ((7 * i) % 5))  # finish out of order
        return i * i, threading.current_thread().name

    for workers in (1, 3):
        out = list(_parallel.ordered_map(slow_square, range(12), workers))
        assert [v for v, _ in out] == [i * i for i in range(12)]
        threads = {name for _, name in out}
        assert (threads == {threading.current_thread().name}) == (workers == 1)

    def fail(i: int) -> int:
        if i == 4:
            raise RuntimeError("chunk 4 failed")
        return i

    with pytest.raises(RuntimeError, match="chunk 4"):
        list(_parallel.ordered_map(fail, range(8), 2))


@pytest.mark.parametrize(
    ("rows_in", "n", "d", "field", "row_stride", "dilation", "weights"),
    [
        (5, 12, 4, (3, 2), 2, 1, "uniform"),
        (5, 24, 3, (3, 3), 1, 2, "period 3"),
        (4, 24, 2, (2, 4), 2, 3, "sparse deficit"),
        (3, 16, 2, (3, 5), 1, 1, "period 2 with zeros"),
    ],
)
def test_periodic_gram_equals_the_direct_gram_of_the_node_inputs(
    rows_in, n, d, field, row_stride, dilation, weights
):
    rng = np.random.default_rng(n + d)
    z = rng.standard_normal((3, rows_in, n, d))
    w = {
        "uniform": np.full(n, 4.0),
        "period 3": np.tile([3.0, 1.0, 2.0], n // 3),
        "sparse deficit": np.where(np.arange(n) % 12 == 5, 2.0, 3.0),
        "period 2 with zeros": np.tile([2.0, 0.0], n // 2),
    }[weights]
    n_rows = (rows_in - field[0]) // row_stride + 1
    plan = plan_weighted_gram(w, rows_in, d, field, row_stride, n_rows, dilation)
    assert plan is not None
    x = np.moveaxis(extract_patches(z, field, (row_stride, 1), n, dilation), -1, 0)  # (F, L, R, n)
    got = plan.gram(z, lambda c: x[..., c])
    f = x.shape[0]
    want = (x * w).reshape(f, -1) @ x.reshape(f, -1).T
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    assert smallest_period(w) == {"uniform": 1, "period 3": 3, "period 2 with zeros": 2}.get(
        weights, 12
    )


def test_irregular_weights_have_no_periodic_plan():
    w = np.random.default_rng(0).integers(1, 5, 24).astype(np.float64)
    assert plan_weighted_gram(w, 4, 2, (2, 3), 2, 2, 1) is None
