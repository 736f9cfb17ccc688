"""Hints where a valid scenario's values look like a unit slip: said once, on stderr, by
``rotlab validate`` and ``rotlab run`` (the run goes on: such values may be meant).

* an angle in radians beyond a turn (15 "rad" of Euler angle is 860°: degrees meant?);
* ω beyond 10⁴ rad/s (~95,000 rpm: rpm or deg/s typed as rad/s?);
* an orbit's altitude below 100 km (km typed where m are asked);
* a body given by its moments whose mass and inertia imply a density far from any material's: the mass spread as a
  uniform ball of the same second moment about its centre, tr S_c = ½ tr I_c = (3/5) m r², has
  density ρ = m / (4/3 π r³); above ``MAX_DENSITY`` (5 × osmium's 22,590 kg/m³) or below
  ``MIN_DENSITY`` (air, 1.2 kg/m³) the mass or the moments are in other units (g, g·cm²?).
"""

from __future__ import annotations

import math

import numpy as np

from rotlab.config.models import Scenario

MAX_OMEGA = 1e4  # rad/s
MAX_DENSITY = 1.2e5  # kg/m³
MIN_DENSITY = 1.2  # kg/m³
MIN_ALTITUDE = 1e5  # m: no orbit lower


def hints(scenario: Scenario) -> list[str]:
    """One line per value that looks like a unit slip (module docstring)."""
    out = []
    initial = scenario.initial
    for key in ("euler_313", "axis_angle"):
        value = getattr(initial, key)
        if value is not None and max(abs(x) for x in value) > 2.0 * math.pi:
            out.append(f"initial.{key} = {list(value)} rad is more than a turn: did you mean {key}_deg (degrees)?")
    speed = math.sqrt(sum(w * w for w in initial.omega))
    if speed > MAX_OMEGA:
        out.append(f"|ω₀| = {speed:.3g} rad/s = {speed * 60 / (2 * math.pi):.3g} rpm = {math.degrees(speed):.3g} deg/s: check the value "
                   "and its unit (omega: rad/s, omega_rpm: rev/min, omega_deg: deg/s)")
    for k, load in enumerate(scenario.loads):
        altitude = getattr(load, "altitude", None)
        if altitude is not None and altitude < MIN_ALTITUDE:
            out.append(f"loads[{k}].altitude = {altitude:g} m: an orbit is at least ~150 km up; altitude is in m (500 km: 500e3)")
    density = implied_density(scenario) if scenario.body.geometry() is None else None  # (a geometry states its own density)
    if density is not None and not MIN_DENSITY <= density <= MAX_DENSITY:
        out.append(f"body: mass {scenario.body.total_mass():g} kg with these moments of inertia is a body of density ~{density:.3g} kg/m³ "
                   "(materials: 1–23,000): is the mass in kg and the inertia in kg·m²?")
    return out


def implied_density(scenario: Scenario) -> float | None:
    """ρ of the uniform ball with the body's mass and second moment about its centre (kg/m³);
    None without a mass."""
    body = scenario.body
    mass = body.total_mass()
    if not mass:
        return None
    r_c = np.asarray(body.centre(), dtype=float)
    central = body.tensor() - mass * (float(r_c @ r_c) * np.eye(3) - np.outer(r_c, r_c))
    second = 0.5 * float(np.trace(central))
    if second <= 0.0:
        return None
    radius = math.sqrt(5.0 * second / (3.0 * mass))
    return mass / (4.0 / 3.0 * math.pi * radius**3)
