"""The one interface every method implements, and what a method returns.

A method turns a ``Scene`` (principal frame, loads as arrays) into the state at the sample
times.  It knows nothing of TOML, recordings or the user's frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Protocol

import numpy as np

if TYPE_CHECKING:
    from rotlab.methods.cost import Estimate, Work
    from rotlab.scene.scene import Scene

ProgressCallback = Callable[[int, int], None]  # (samples done, samples total)
LocalSolution = Callable[[np.ndarray, float, float], np.ndarray]  # (state at t0, t0, t1) → the state at t1


@dataclass
class Settings:
    """Accuracy settings shared by all methods (each uses what applies to it)."""

    step: float | None = None
    rtol: float = 1e-10
    atol: float = 1e-12
    max_steps: int = 200_000_000
    order: int | None = None  # composition / method order where a method offers several

    @classmethod
    def of(cls, solver: object) -> Settings:
        """The settings a scenario's ``[solver]`` table gives (``rotlab.config.models.Solver``)."""
        return cls(step=solver.step, rtol=solver.rtol, atol=solver.atol, max_steps=solver.max_steps, order=solver.order)

    def at_tolerance(self, rtol: float, order: int | None) -> Settings:
        """An adaptive run at local tolerance ``rtol`` (atol scaled alike) and ``order``, no step
        (``auto``'s choice of an error-controlled method)."""
        return Settings(step=None, rtol=rtol, atol=self.atol * (rtol / self.rtol), max_steps=self.max_steps, order=order)


@dataclass
class Solution:
    """State at the sample times, principal body frame.

    ``state`` rows in the layout of ``rotlab.core.state``: Λ (scalar first), ω (body), work W of
    the non-conservative loads.  Only the first ``valid`` rows are meaningful: a run that failed keeps
    what it computed before the failure and says why in ``failure``.
    """

    t: np.ndarray
    state: np.ndarray
    valid: int
    steps: int = 0
    rejected_steps: int = 0
    rhs_evaluations: int = 0
    failure: str | None = None
    interrupted: bool = False  # the failure is the user's Ctrl-C
    details: dict[str, object] = field(default_factory=dict)


FIXED, ADAPTIVE, NO_STEPS = "fixed", "adaptive", "none"  # values of ``Method.stepping``


class Method(Protocol):
    """What every method declares; tools (``choose``, bench, sweeps) rely on these and nothing else.

    ``stepping``: FIXED (equal steps from ``solver.step`` or from ``solver.rtol`` through a
    probe, see ``FixedStepping``), ADAPTIVE (steps chosen from ``rtol``/``atol`` as it goes) or
    NO_STEPS (a closed form evaluated at the samples).  ``adaptive`` is ``stepping == ADAPTIVE``.
    ``orders``: the orders ``solver.order`` may choose (empty: the one ``order_of_accuracy``,
    None for NO_STEPS).  ``evaluations_per_step(scene, order)``: right-hand-side (or force)
    evaluations per accepted step, the method's cost unit (0 when it evaluates none).
    ``auto_estimates`` / ``auto_settings``: what ``auto`` (``rotlab.methods.choose``) may run it
    with and at what expected cost; ``given_step_preference``: its rank among the FIXED methods
    when ``auto`` is given ``solver.step`` (None: never); ``ends_steps_at_switches``: its steps
    end where a formula's abs, sign, min or max switches (else they cross the kink, and its
    error there is not controlled).
    """

    name: str
    summary: str
    stepping: str
    adaptive: bool
    orders: tuple[int, ...]
    order_of_accuracy: int | None
    given_step_preference: int | None
    ends_steps_at_switches: bool

    def evaluations_per_step(self, scene: Scene, order: int | None) -> int:
        """Right-hand-side evaluations per step for ``scene`` at ``order``."""

    def unsupported(self, scene: Scene) -> str | None:
        """Why this method cannot run ``scene`` (None when it can)."""

    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        """The state at the sample times ``t`` (``t[0]`` is the initial time)."""

    def local_solution(self, scene: Scene, t: np.ndarray, settings: Settings) -> LocalSolution:
        """The method's own solution between two samples of its run over the sample times ``t``,
        from any state: fn(y, t0, t1) is the state at t1 from y at t0 as the run steps it, so
        that fn(y_k, t_k, t_{k+1}) is the run's next sample (events are located on it,
        ``rotlab.events``)."""

    def auto_estimates(self, scene: Scene, settings: Settings, work: Work) -> list[Estimate]:
        """The runs ``auto`` may make with this method on ``scene`` (each an order and setting),
        with their expected cost and error (``rotlab.methods.cost``); empty: never by cost."""

    def auto_settings(self, estimate: Estimate, settings: Settings) -> Settings:
        """The settings it runs ``estimate`` with, from the user's ``settings``."""


class FixedStepping(Method, Protocol):
    """A FIXED-stepping method also says the step it would take (``rotlab.methods.fixed_step``)."""

    def order(self, settings: Settings) -> int:
        """The order it runs at (``settings.order`` checked against ``orders``)."""

    def step_for_tolerance(self, scene: Scene, t: np.ndarray, rtol: float, order: int) -> float:
        """The step that meets ``rtol`` over the span of ``t``, from a probe run."""
