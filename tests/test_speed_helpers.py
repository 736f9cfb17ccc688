"""Helpers of the speed work: the vectorised cross product (bitwise equal to ``np.cross``) and the
clock that keeps numba compilation out of a run's integration time."""

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
    from rotlab.methods import taylor
    from rotlab.scene.scene import build_scene
    from tests.conftest import CONFIGS

    base = rotlab.load(CONFIGS / "general.toml")
    spun = rotlab.load(CONFIGS / "general.toml", overrides={"initial.omega": [0.5, -0.3, 20.0]})
    pushed = rotlab.load(CONFIGS / "general.toml", overrides={"loads[1].value[2]": 0.03})
    a, b, c = (build_scene(s) for s in (base, spun, pushed))
    assert a.model is b.model and a.model is not c.model
    constants = [s.shared("taylor", lambda s=s: taylor.kernel_constants(s)) for s in (a, b, c)]
    assert constants[0] is constants[1] and constants[0] is not constants[2]
    np.testing.assert_array_equal(c.model.terms, build_scene(pushed).loads.terms)  # its own loads, not a's
    assert c.model.terms[0, 5] == 0.03 and a.model.terms[0, 5] == 0.02

    def torque(t, q, omega):
        return np.zeros(3)

    with_fn = [build_scene(base, torque=torque) for _ in range(2)]
    assert with_fn[0].content_key is None and with_fn[0].model is not with_fn[1].model  # a Python torque: per scene
