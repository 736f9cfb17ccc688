"""Helpers of the speed work: the vectorised cross product (bitwise equal to ``np.cross``), the
row arithmetic (bitwise equal to NumPy's reductions), and the clock that keeps numba compilation
out of a run's integration time."""

from __future__ import annotations

import time

import numpy as np
import pytest

from rotlab.core.quaternion import cross_array
from rotlab.methods.compile_time import compile_clock


@pytest.mark.parametrize("shapes", [((5, 3), (5, 3)), ((3,), (7, 3)), ((4, 1, 3), (1, 6, 3)), ((3,), (3,))])
def test_cross_array_is_np_cross_bit_for_bit(shapes):
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=shapes[0]) * 1e3, rng.normal(size=shapes[1]) * 1e-3
    assert np.array_equal(cross_array(a, b), np.cross(a, b))


@pytest.mark.parametrize("shape", [(7, 3), (5, 9, 4), (3,), (2, 1, 3)])
def test_row_arithmetic_is_numpys_bit_for_bit(shape):
    """``rotlab.rows`` (one component at a time) against ``np.sum``, ``np.linalg.norm`` and the
    division by it, on values spread over 16 decades: the same floating-point results."""
    from rotlab.rows import row_dot, row_norm, unit_rows

    rng = np.random.default_rng(5)
    a = rng.normal(size=shape) * 10.0 ** rng.integers(-8, 8, size=shape)
    b = rng.normal(size=shape)
    assert np.array_equal(row_dot(a, b), np.sum(a * b, axis=-1))
    assert np.array_equal(row_norm(a), np.linalg.norm(a, axis=-1))
    assert np.array_equal(unit_rows(a), a / np.linalg.norm(a, axis=-1, keepdims=True))


def test_the_array_rotation_is_the_kernels_rotation_bit_for_bit():
    """``rotate_to_space_array`` (one component at a time) against the numba kernels' scalar
    ``rotate_to_space``, row by row, broadcasting a fixed vector or quaternion."""
    from rotlab.core.quaternion import rotate_to_space, rotate_to_space_array

    rng = np.random.default_rng(9)
    q, v = rng.normal(size=(200, 4)), rng.normal(size=(200, 3)) * 10.0 ** rng.integers(-6, 6, size=(200, 1))
    expected = np.array([rotate_to_space.py_func(*qk, *vk) for qk, vk in zip(q, v)])
    assert np.array_equal(rotate_to_space_array(q, v), expected)
    assert np.array_equal(rotate_to_space_array(q, v[0]), rotate_to_space_array(q, np.broadcast_to(v[0], v.shape)))
    assert np.array_equal(rotate_to_space_array(q[0], v), rotate_to_space_array(np.broadcast_to(q[0], q.shape), v))


def test_compile_clock_counts_a_compilation_and_not_the_run():
    from numba import njit

    @njit(cache=False)
    def busy(n):
        s = 0.0
        for i in range(n):
            s += i * 0.5
        return s

    with compile_clock() as first:
        started = time.perf_counter()
        busy(10)
        total = time.perf_counter() - started
    assert 0.0 < first.seconds <= total  # the first call compiles: that time is on the clock
    with compile_clock() as second:
        busy(10)
    assert second.seconds == 0.0  # compiled already: nothing to count


def test_the_clock_reads_a_compile_in_progress_and_announces_it():
    from numba import njit

    @njit(cache=False)
    def other(n):
        return n * 2.0

    heard: list[tuple[bool, float]] = []
    with compile_clock(announce=lambda active: heard.append((active, clock.seconds))) as clock:
        other(1.0)
    assert [active for active, _ in heard] == [True, False]  # one compile, outermost start and end only
    started, ended = heard[0][1], heard[1][1]
    assert 0.0 <= started < ended <= clock.seconds  # read while numba held its lock: the hold counts already
    with compile_clock(announce=lambda active: heard.append((active, 0.0))):
        other(2.0)
    assert len(heard) == 2  # no compile, nothing announced


def test_scenes_with_equal_loads_share_their_kernel_constants():
    """A sweep over initial states or a loop over ``simulate`` builds a new scene each call; what
    depends only on the loads and the principal moments (the model, taylor's force map) is built
    once and shared by content, and a change of any load or moment gets its own."""
    import rotlab
    from rotlab.methods.catalog import taylor
    from rotlab.scene.scene import build_scene
    from tests.conftest import CONFIGS

    base = rotlab.load(CONFIGS / "general.toml")
    spun = rotlab.load(CONFIGS / "general.toml", overrides={"initial.omega": [0.5, -0.3, 20.0]})
    pushed = rotlab.load(CONFIGS / "general.toml", overrides={"loads[1].value[2]": 0.03})
    a, b, c = (build_scene(s) for s in (base, spun, pushed))
    assert a.model is b.model and a.model is not c.model
    constants = [s.rigid.kernel_constants("taylor", None, lambda s=s: taylor.kernel_constants(s)) for s in (a, b, c)]
    assert constants[0] is constants[1] and constants[0] is not constants[2]
    np.testing.assert_array_equal(c.model.terms, build_scene(pushed).loads.terms)  # its own loads, not a's
    assert c.model.terms[0, 5] == 0.03 and a.model.terms[0, 5] == 0.02

    def torque(t, q, omega):
        return np.zeros(3)

    with_fn = [build_scene(base, torque=torque) for _ in range(2)]
    assert with_fn[0].content_key is None and with_fn[0].model is not with_fn[1].model  # a Python torque: per scene


def test_scenes_of_equal_bodies_and_loads_share_their_rigid_part_and_keep_their_own_state():
    """``build_scene`` builds the principal axes, the load arrays and the classification once per
    body-with-loads (frozen models compared by value); the initial state is each scenario's own,
    and it equals a scene built without the shared part."""
    import rotlab
    from rotlab.core import quaternion as quat
    from rotlab.scene import scene as scenes
    from tests.conftest import CONFIGS

    base = rotlab.load(CONFIGS / "general.toml")  # a full inertia tensor: principal axes ≠ the user's
    turned = rotlab.load(CONFIGS / "general.toml", overrides={"initial.omega": [1.0, 2.0, 3.0], "initial.axis_angle": [0.0, 0.4, 0.2]})
    heavier = rotlab.load(CONFIGS / "general.toml", overrides={"body.mass": 1.3})
    a, b, c = (scenes.build_scene(s) for s in (base, turned, heavier))
    assert a.rigid is b.rigid and a.loads is b.loads and a.axes is b.axes and a.loads is not c.loads
    assert c.loads.forces[0, 5] == pytest.approx(-1.3 * 9.81) and a.loads.forces[0, 5] == pytest.approx(-1.2 * 9.81)
    rigid = scenes._build_rigid(turned, None)  # unshared: the same numbers
    np.testing.assert_array_equal(b.omega0, rigid.axes.T @ np.array([1.0, 2.0, 3.0]))
    expected_q0 = quat.multiply_array(scenes.initial_quaternion(turned.initial), rigid.axes_quaternion)
    np.testing.assert_array_equal(b.q0, expected_q0)
    assert not np.array_equal(a.q0, b.q0)
    assert b.content_key == (rigid.moments.tobytes(), scenes.loads_key(rigid.loads))
    assert not b.is_principal and scenes.build_scene(rotlab.load(CONFIGS / "euler.toml")).is_principal


def test_the_single_quaternion_product_is_the_array_product_bit_for_bit():
    from rotlab.core.quaternion import multiply, multiply_array

    rng = np.random.default_rng(3)
    for _ in range(2000):
        a, b = rng.normal(size=4) * 10.0 ** rng.integers(-8, 8), rng.normal(size=4)
        assert np.array_equal(multiply(a, b), multiply_array(a, b))


def test_the_projection_of_a_rotated_vector_equals_rotating_it():
    """``projection_array`` ((R(Λ) w)·v in one product, the sweep's nutation) against rotating
    every w and taking the dot product: within 16 ε |w||v| on random unit quaternions (each side
    sums ~10 rounded terms of size ≤ |w||v|, and |Λ| = 1 only to rounding; measured ≤ 5.6 ε)."""
    from rotlab.core.quaternion import projection_array, rotate_to_space_array

    rng = np.random.default_rng(11)
    q = rng.normal(size=(500, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for _ in range(40):
        w, v = rng.normal(size=3) * 10.0 ** rng.integers(-3, 3), rng.normal(size=3)
        rotated = rotate_to_space_array(q, np.broadcast_to(w, (500, 3))) @ v
        bound = 16.0 * np.finfo(float).eps * np.linalg.norm(w) * np.linalg.norm(v)
        assert np.max(np.abs(projection_array(q, w, v) - rotated)) <= bound


def test_the_projection_of_stacked_runs_is_each_runs_projection():
    """``projection_array`` of B runs stacked ((B, N, 4) rows, one w and v per run) equals each
    run's own projection to the last bit: the same products, the same order of the sums."""
    from rotlab.core.quaternion import projection_array

    rng = np.random.default_rng(12)
    q = rng.normal(size=(3, 50, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    w, v = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    stacked = projection_array(q, w, v)
    for b in range(3):
        assert np.array_equal(stacked[b], projection_array(q[b], w[b], v[b]))


def test_the_sweeps_nutation_is_the_angle_of_the_users_body_axis_in_space():
    """``nutation`` works in the principal frame (R(Λ_user) e = R(Λ_P) Pᵀ e), on runs stacked; on
    a body whose principal axes are not the user's (general.toml), two runs from different ω₀,
    each run's ϑ equals the angle between the user's axis rotated by the user's Λ and that run's
    reference direction, within 1e-7 rad (arccos near 0 or π amplifies rounding of the cosine to ~√ε)."""
    import rotlab
    from rotlab.core.quaternion import rotate_to_space_array
    from rotlab.observables import nutation, reference_axes
    from rotlab.trajectory import stack_runs
    from tests.conftest import CONFIGS

    trajectories = [rotlab.simulate(CONFIGS / "general.toml", duration=1.0, overrides={"initial.omega": omega})
                    for omega in ([0.3, 2.0, 9.0], [6.0, -1.0, 0.5])]
    assert not trajectories[0].scene.is_principal
    runs = stack_runs(trajectories)
    e, d = reference_axes(runs)
    theta = nutation(runs)
    assert not np.allclose(e[0], e[1]) or not np.allclose(d[0], d[1])  # two different reference pairs
    for b, traj in enumerate(trajectories):
        q = traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True)
        direct = np.arccos(np.clip(rotate_to_space_array(q, np.broadcast_to(e[b], (len(q), 3))) @ d[b], -1.0, 1.0))
        np.testing.assert_allclose(theta[b], direct, rtol=0.0, atol=1e-7)
        assert np.ptp(direct) > 0.01  # the axis moves: the comparison is not of constants


def test_the_kernels_bisection_is_numpys_searchsorted_right():
    """``count_at_or_below`` (the kernels' next-breakpoint search) against
    ``np.searchsorted(..., side="right")`` on sorted arrays with repeats, at the values
    themselves, between them, beyond both ends and on an empty array."""
    from rotlab.core.dynamics import count_at_or_below

    rng = np.random.default_rng(5)
    for size in (0, 1, 2, 3, 8, 33):
        values = np.sort(rng.integers(0, 6, size=size).astype(float))
        probes = np.concatenate([values, values + 0.5, values - 0.5, [-1e300, 1e300, -np.inf, np.inf]])
        for x in probes:
            assert count_at_or_below(values, float(x)) == np.searchsorted(values, x, side="right")


def test_rotlabs_workers_keep_their_heap_between_large_temporaries():
    """A local worker (``rotlab.parallel``) reuses freed heap for the next 0.1–1 MB NumPy temporary
    instead of faulting in fresh pages (``rotlab.heap``); with glibc's defaults the 4 MB block is
    mapped and given back, and the heap holds ~0 bytes free after it."""
    import ctypes
    import sys

    from rotlab.parallel import run_tasks
    from tests.helpers import heap_free_after_a_large_temporary

    if not sys.platform.startswith("linux") or not hasattr(ctypes.CDLL(None), "mallinfo2"):
        pytest.skip("glibc's mallinfo2 is needed to see the heap")
    run = run_tasks(heap_free_after_a_large_temporary, [()], jobs=1, preload=())
    assert run.ends[0].result >= 4 << 20



def test_a_long_runs_heap_trimmer_gives_free_heap_pages_back():
    """``rotlab.heap.HeapTrimmer`` (called as a streamed run flushes its chunks) returns free pages
    inside glibc's heap to the system: 64 MB of freed NumPy blocks pinned below a live one stay
    resident until it trims, and not after (resident memory read from /proc, in a fresh process)."""
    import ctypes
    import subprocess
    import sys

    if not sys.platform.startswith("linux") or not hasattr(ctypes.CDLL(None), "malloc_trim"):
        pytest.skip("glibc's malloc_trim is what HeapTrimmer calls")
    code = """
import numpy as np
from rotlab.heap import HeapTrimmer, keep_heap
def resident():
    return next(int(line.split()[1]) for line in open('/proc/self/status') if line.startswith('VmRSS')) * 1024
assert keep_heap()  # 4 MB blocks from the heap, and free heap kept (as a worker does)
blocks = [np.ones(1 << 19) for _ in range(16)]
pin = np.ones(1 << 19)  # above them: the heap's top cannot shrink past it
del blocks
before = resident()
HeapTrimmer(every=0.0).trim()
print(before - resident())
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert int(out.stdout) >= 56 << 20, out.stdout


def test_the_heap_helpers_do_nothing_where_the_c_library_lacks_them(monkeypatch):
    """On a C library without ``mallopt``/``malloc_trim`` (macOS, musl, Windows) ``keep_heap``
    says False and ``HeapTrimmer.trim`` does nothing, instead of raising."""
    from rotlab import heap

    assert heap._c_function("rotlab_has_no_such_function", (), None) is None
    monkeypatch.setattr(heap, "_c_function", lambda name, argtypes, restype: None)
    assert heap.keep_heap() is False
    trimmer = heap.HeapTrimmer(every=0.0)
    trimmer.trim()
    assert trimmer._trim is None
