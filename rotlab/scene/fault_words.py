"""A load's fault (``rotlab.core.faults``), in the words of a run's failure message: which load,
at what time and state, and what was wrong.  One line, the load named as in the scenario
(``loads[0].torque[1] = 't**(-1)'``) or as the Python function passed to ``rotlab.simulate``."""

from __future__ import annotations

import numpy as np

from rotlab.core import faults
from rotlab.scene.loads import LoadArrays


def explain(fault: faults.Fault, loads: LoadArrays) -> str:
    """Why the run stopped, from the fault a compiled load recorded (not INTERRUPTED)."""
    where = f"at t = {fault.t:.9g} s (ω = {_vector(fault.omega)} rad/s, q = {_vector(fault.quaternion)}, body frame)"
    if fault.kind == faults.FORMULA_NOT_FINITE:
        name = loads.formula_names[fault.load][fault.component]
        if fault.detail >= 1.0:
            return (f"{name} has no finite Taylor series {where}: its coefficient of order {fault.detail:.0f} is not finite "
                    "(the formula is not smooth there, or its derivatives overflow; method dop853 or rk4 can step across a kink)")
        return f"{name} is not finite {where}"
    name = getattr(loads.user_function, "__name__", "torque")
    call = f"the Python torque {name}(t, q, omega)"
    if fault.kind == faults.CALLABLE_SHAPE:
        return f"{call} returned {fault.detail:.0f} values {where}; it must return 3 (Mx, My, Mz)"
    if fault.kind == faults.CALLABLE_NOT_FINITE:
        return f"{call} returned a value that is not finite (M[{fault.component}]) {where}"
    return f"{call} raised {_raised(loads.user_function, fault)} {where}"


def _raised(function: object, fault: faults.Fault) -> str:
    """What the Python function raises at the fault's state, run by Python itself."""
    plain = getattr(function, "py_func", function)
    try:
        plain(fault.t, np.array(fault.quaternion), np.array(fault.omega))  # type: ignore[operator]
    except Exception as exc:  # noqa: BLE001 - whatever the user's function raises is the answer
        return f"{type(exc).__name__}: {exc}"[:200]
    return "an exception in numba's compiled code (Python runs it without one: numba raises on a division by 0)"


def _vector(values: tuple[float, ...]) -> str:
    return np.array2string(np.asarray(values), precision=6, separator=", ")
