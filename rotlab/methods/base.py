"""The one interface every method implements, and what a method returns.

A method turns a ``Scene`` (principal frame, loads as arrays) into the state at the sample
times.  It knows nothing of TOML, recordings or the user's frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Protocol

import numpy as np

if TYPE_CHECKING:
    from rotlab.scene.scene import Scene

ProgressCallback = Callable[[int, int], None]  # (samples done, samples total)


@dataclass
class Settings:
    """Accuracy settings shared by all methods (each uses what applies to it)."""

    step: float | None = None
    rtol: float = 1e-10
    atol: float = 1e-12
    max_steps: int = 200_000_000
    order: int | None = None  # composition / method order where a method offers several


@dataclass
class Solution:
    """State at the sample times, principal body frame.

    ``state[:, 0:4]`` Λ (scalar first), ``state[:, 4:7]`` ω (body), ``state[:, 7]`` work W of the
    non-conservative loads.  Only the first ``valid`` rows are meaningful: a run that failed keeps
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


class Method(Protocol):
    name: str
    summary: str

    def unsupported(self, scene: Scene) -> str | None:
        """Why this method cannot run ``scene`` (None when it can)."""

    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        """The state at the sample times ``t`` (``t[0]`` is the initial time)."""
