"""The torque of a scene's loads on the body, body components (principal frame): the one
compiled module that reads the load fields of the model (``rotlab.scene.loads.Model``).

* constant space-frame forces F at body points p:  M = Σ p × (Rᵀ F)         (conservative)
* torque terms: offset + amplitude · sin(w t + φ) inside [on, off), body or space frame (Rᵀ M)
* tables: piecewise-linear M(t), body or space frame
* damping: M = −k ω
* expressions: components given as programs of (t, ω, Λ, γ, L) in the user's body frame,
  a torque or a force at a body point, body or space frame, inside [on, off)
All but the forces do work W (Ẇ = M_nc · ω).

A scene pays only for the loads it has: a load group that is None in the model compiles to
nothing (``overload`` specialises on the type, and numba caches each specialisation on disk).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from rotlab.core.expressions import call_formulas, call_load_formulas, constants_address, series_step, switch_limit
from rotlab.core.faults import FORMULA_NOT_FINITE, record
from rotlab.core.model import USER_BUFFER
from rotlab.core.quaternion import N_PRODUCTS, qmul, rotate_quadratic, rotate_to_body
from rotlab.core.state import P0, Q0, STATE_SIZE
from rotlab.core.targets import overload

# columns of a torque term, a table, an expression load (written by rotlab.scene.loads)
BODY, SPACE = 0.0, 1.0  # a load's frame column (T_FRAME, TB_FRAME, EX_FRAME): the kernels read any value ≠ 0 as space
F_POINT, F_FORCE = 0, 3
F_COLUMNS = 6
T_FRAME, T_ON, T_OFF, T_OFFSET, T_AMP, T_W, T_PHASE = 0, 1, 2, 3, 6, 9, 10
T_COLUMNS = 11
TB_FRAME, TB_ON, TB_OFF, TB_FIRST, TB_STOP = 0, 1, 2, 3, 4
TB_COLUMNS = 5
EX_FRAME, EX_ON, EX_OFF, EX_FORCE, EX_POINT, EX_UP, EX_UP2, EX_RATE, EX_PROGRAMS = 0, 1, 2, 3, 4, 7, 10, 13, 14
EX_COLUMNS = 20
N_INPUTS = 14
# The model's fields that hold no load doing work (the driven rotors' reaction is ``drive_rotors``'s):
# a scene whose other fields are all None has no non-conservative torque.  Listed this way round, a
# field added to the model counts as a load that may do work until it is listed here.
WORKLESS_FIELDS = ("euler", "breaks", "forces", "rotors", "drives")


def conservative_torque(y, model):
    """Σ p × (Rᵀ F) over the model's constant space-frame forces; body components."""
    raise NotImplementedError("compiled only")


def nonconservative_torque(t, y, model):
    """Terms + tables + damping + expressions + a Python torque at time t, body components; None
    when the scene has none of them (a compile-time None: ``plus_torque`` and ``power`` then cost
    nothing, where adding a torque of 0 or its work 0 · ω are operations the compiler must keep)."""
    raise NotImplementedError("compiled only")


def plus_torque(c, n):
    """c + n, body components; c itself when n is None (``nonconservative_torque``)."""
    raise NotImplementedError("compiled only")


def power(n, p, q, r):
    """Ẇ = n · ω, the rate of work of the non-conservative torque n; 0 when n is None."""
    raise NotImplementedError("compiled only")


def _forces(y, forces):
    raise NotImplementedError("compiled only")


def _terms(t, y, terms):
    raise NotImplementedError("compiled only")


def _tables(t, y, tables, table_t, table_v):
    raise NotImplementedError("compiled only")


def _damping(y, damping):
    raise NotImplementedError("compiled only")


def _expressions(t, y, ex):
    raise NotImplementedError("compiled only")


def has_forces(model):
    """Whether the model has constant space-frame forces (a compile-time constant)."""
    raise NotImplementedError("compiled only")


@overload(has_forces, inline="always")
def _has_forces(model):
    value = not isinstance(model.types[model.fields.index("forces")], types.NoneType)
    return lambda model: value


@overload(conservative_torque, inline="always")
def _conservative_torque(y, model):
    return lambda y, model: _forces(y, model.forces)


@overload(nonconservative_torque, inline="always")
def _nonconservative_torque(t, y, model):
    if all(isinstance(kind, types.NoneType) for field, kind in zip(model.fields, model.types) if field not in WORKLESS_FIELDS):
        return lambda t, y, model: None

    def impl(t, y, model):
        ax, ay, az = _terms(t, y, model.terms)
        bx, by, bz = _tables(t, y, model.tables, model.table_t, model.table_v)
        cx, cy, cz = _damping(y, model.damping)
        dx, dy, dz = _expressions(t, y, model.expressions)
        ex, ey, ez = _user(t, y, model.user)
        return ax + bx + cx + dx + ex, ay + by + cy + dy + ey, az + bz + cz + dz + ez

    return impl


@overload(plus_torque, inline="always")
def _plus_torque(c, n):
    if isinstance(n, types.NoneType):
        return lambda c, n: c
    return lambda c, n: (c[0] + n[0], c[1] + n[1], c[2] + n[2])


@overload(power, inline="always")
def _power(n, p, q, r):
    if isinstance(n, types.NoneType):
        return lambda n, p, q, r: 0.0
    return lambda n, p, q, r: n[0] * p + n[1] * q + n[2] * r


def _user(t, y, user):
    raise NotImplementedError("compiled only")


@overload(_user, inline="always")
def _user_impl(t, y, user):
    if isinstance(user, types.NoneType):
        return lambda t, y, user: (0.0, 0.0, 0.0)

    def impl(t, y, user):
        q0, q1, q2, q3 = _to_user_quaternion(user.axes_q, y[Q0], y[Q0 + 1], y[Q0 + 2], y[Q0 + 3])
        w0, w1, w2 = _to_user(user.axes, y[P0], y[P0 + 1], y[P0 + 2])
        b = np.empty(USER_BUFFER)
        b[0], b[1], b[2], b[3], b[4], b[5], b[6] = q0, q1, q2, q3, w0, w1, w2
        user.fn(t, b.ctypes)
        mx, my, mz = b[7], b[8], b[9]
        if user.frame != 0.0:
            return rotate_to_body(y[Q0], y[Q0 + 1], y[Q0 + 2], y[Q0 + 3], mx, my, mz)
        return _to_principal(user.axes, mx, my, mz)

    return impl


@overload(_forces, inline="always")
def _forces_impl(y, forces):
    if isinstance(forces, types.NoneType):
        return lambda y, forces: (0.0, 0.0, 0.0)
    return forces_torque


@overload(_terms, inline="always")
def _terms_impl(t, y, terms):
    if isinstance(terms, types.NoneType):
        return lambda t, y, terms: (0.0, 0.0, 0.0)
    return terms_torque


@overload(_tables, inline="always")
def _tables_impl(t, y, tables, table_t, table_v):
    if isinstance(tables, types.NoneType):
        return lambda t, y, tables, table_t, table_v: (0.0, 0.0, 0.0)
    return tables_torque


@overload(_damping, inline="always")
def _damping_impl(y, damping):
    if isinstance(damping, types.NoneType):
        return lambda y, damping: (0.0, 0.0, 0.0)
    return damping_torque


# The torque of each load group, written once.  The kernels inline each body through the overloads
# above (numba inlines it where the kernel is typed: the fastest steps, every load in registers);
# the recording's load view and the bench's peers call it compiled apart (the ``_*_called`` below:
# argument types that do not depend on the scene, so each is compiled once and cached on disk).


@njit(cache=True, inline="always")
def force_torque(y, forces, k):
    """p × (Rᵀ F) of force row k of ``forces_torque``."""
    fx, fy, fz = rotate_to_body(y[Q0], y[Q0 + 1], y[Q0 + 2], y[Q0 + 3], forces[k, F_FORCE], forces[k, F_FORCE + 1], forces[k, F_FORCE + 2])
    px, py, pz = forces[k, F_POINT], forces[k, F_POINT + 1], forces[k, F_POINT + 2]
    return py * fz - pz * fy, pz * fx - px * fz, px * fy - py * fx


def forces_torque(y, forces):
    """Σ_k p_k × (Rᵀ F_k): constant space-frame forces F (columns F_FORCE) at body points p
    (columns F_POINT).  The sum starts at the first force's torque, not at 0 + it (a scene's one
    force, gravity, costs no additions)."""
    if forces.shape[0] == 0:
        return 0.0, 0.0, 0.0
    cx, cy, cz = force_torque(y, forces, 0)
    for k in range(1, forces.shape[0]):
        mx, my, mz = force_torque(y, forces, k)
        cx += mx
        cy += my
        cz += mz
    return cx, cy, cz


def terms_torque(t, y, terms):
    """Σ over terms acting at t (on ≤ t < off) of offset + amplitude · sin(w t + φ), body
    components (Rᵀ M for a space-frame term)."""
    nx = ny = nz = 0.0
    for k in range(terms.shape[0]):
        if terms[k, T_ON] <= t < terms[k, T_OFF]:
            mx, my, mz = terms[k, T_OFFSET], terms[k, T_OFFSET + 1], terms[k, T_OFFSET + 2]
            if terms[k, T_W] != 0.0:
                s = math.sin(terms[k, T_W] * t + terms[k, T_PHASE])
                mx += terms[k, T_AMP] * s
                my += terms[k, T_AMP + 1] * s
                mz += terms[k, T_AMP + 2] * s
            mx, my, mz = _in_body(y, terms[k, T_FRAME], mx, my, mz)
            nx += mx
            ny += my
            nz += mz
    return nx, ny, nz


def tables_torque(t, y, tables, table_t, table_v):
    """Σ over tables acting at t of the piecewise-linear M(t) (``table_value``), body components."""
    nx = ny = nz = 0.0
    for k in range(tables.shape[0]):
        if tables[k, TB_ON] <= t < tables[k, TB_OFF]:
            mx, my, mz = table_value(table_t, table_v, int(tables[k, TB_FIRST]), int(tables[k, TB_STOP]), t)
            mx, my, mz = _in_body(y, tables[k, TB_FRAME], mx, my, mz)
            nx += mx
            ny += my
            nz += mz
    return nx, ny, nz


def damping_torque(y, damping):
    """−k ω."""
    return -damping * y[P0], -damping * y[P0 + 1], -damping * y[P0 + 2]


@overload(_expressions, inline="always")
def _expressions_impl(t, y, ex):
    if isinstance(ex, types.NoneType):
        return lambda t, y, ex: (0.0, 0.0, 0.0)

    def impl(t, y, ex):
        return expression_torque(t, y, ex.rows, ex.fn, constants_address(ex.consts), ex.axes, ex.axes_q, ex.moments)

    return impl


@njit(cache=True)
def _in_body(y, frame, mx, my, mz):
    """Body components of a vector given in the body (frame 0) or the space frame (Rᵀ M)."""
    if frame != 0.0:
        return rotate_to_body(y[Q0], y[Q0 + 1], y[Q0 + 2], y[Q0 + 3], mx, my, mz)
    return mx, my, mz


@njit(cache=True)
def table_segment(tt, first, stop, t):
    """The row lo of rows [first, stop) of a table with tt[lo] ≤ t < tt[lo + 1]; −1 outside."""
    if t < tt[first] or t >= tt[stop - 1]:
        return -1
    lo, hi = first, stop - 1  # bisection: tt[lo] <= t < tt[hi]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if tt[mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def table_value(tt, tv, first, stop, t):
    """Piecewise-linear interpolation in rows [first, stop) of a table; zero outside."""
    lo = table_segment(tt, first, stop, t)
    if lo < 0:
        return 0.0, 0.0, 0.0
    hi = lo + 1
    s = (t - tt[lo]) / (tt[hi] - tt[lo])
    return (
        tv[lo, 0] + s * (tv[hi, 0] - tv[lo, 0]),
        tv[lo, 1] + s * (tv[hi, 1] - tv[lo, 1]),
        tv[lo, 2] + s * (tv[hi, 2] - tv[lo, 2]),
    )


@njit(cache=True, forceinline=True)
def _to_user(axes, x, y, z):
    """Principal-frame components → the user's body frame (r_U = axes r_P)."""
    return (axes[0, 0] * x + axes[0, 1] * y + axes[0, 2] * z,
            axes[1, 0] * x + axes[1, 1] * y + axes[1, 2] * z,
            axes[2, 0] * x + axes[2, 1] * y + axes[2, 2] * z)


@njit(cache=True, forceinline=True)
def _to_principal(axes, x, y, z):
    """The user's body frame → principal components (r_P = axesᵀ r_U)."""
    return (axes[0, 0] * x + axes[1, 0] * y + axes[2, 0] * z,
            axes[0, 1] * x + axes[1, 1] * y + axes[2, 1] * z,
            axes[0, 2] * x + axes[1, 2] * y + axes[2, 2] * z)


@njit(cache=True, forceinline=True)
def _to_user_quaternion(axes_q, l0, l1, l2, l3):
    """Λ_U = Λ ∘ Λ̃_axes (linear in Λ: also maps Taylor coefficients)."""
    return qmul(l0, l1, l2, l3, axes_q[0], -axes_q[1], -axes_q[2], -axes_q[3])


@njit(cache=True, forceinline=True)
def expression_inputs(t, y, rows, k, axes, axes_q, moments):
    """(t, ω, Λ, γ, L) in the user's body frame for expression load ``rows[k]`` (14 numbers):
    ω_U = axes ω, L_U = axes (I ω), Λ_U = Λ ∘ Λ̃_axes, γ_U = axes Rᵀ up(t) with
    up(t) = cos(ν t) u + sin(ν t) v (space frame; ν = 0: a fixed direction)."""
    p, q, r = y[P0], y[P0 + 1], y[P0 + 2]
    w0, w1, w2 = _to_user(axes, p, q, r)
    l0, l1, l2, l3 = y[Q0], y[Q0 + 1], y[Q0 + 2], y[Q0 + 3]
    u0, u1, u2, u3 = _to_user_quaternion(axes_q, l0, l1, l2, l3)
    c, s = 1.0, 0.0
    if rows[k, EX_RATE] != 0.0:
        c, s = np.cos(rows[k, EX_RATE] * t), np.sin(rows[k, EX_RATE] * t)
    ux = c * rows[k, EX_UP] + s * rows[k, EX_UP2]
    uy = c * rows[k, EX_UP + 1] + s * rows[k, EX_UP2 + 1]
    uz = c * rows[k, EX_UP + 2] + s * rows[k, EX_UP2 + 2]
    gx, gy, gz = rotate_to_body(l0, l1, l2, l3, ux, uy, uz)
    g0, g1, g2 = _to_user(axes, gx, gy, gz)
    m0, m1, m2 = _to_user(axes, moments[0] * p, moments[1] * q, moments[2] * r)
    return t, w0, w1, w2, u0, u1, u2, u3, g0, g1, g2, m0, m1, m2


@njit(cache=True, forceinline=True)
def expression_output(y, rows, k, axes, vx, vy, vz):
    """The torque (principal body frame) of the evaluated components v: a torque or a force at
    the load's point, in the body frame (user's axes) or the space frame."""
    if rows[k, EX_FRAME] != 0.0:
        vx, vy, vz = rotate_to_body(y[Q0], y[Q0 + 1], y[Q0 + 2], y[Q0 + 3], vx, vy, vz)
    else:
        vx, vy, vz = _to_principal(axes, vx, vy, vz)
    if rows[k, EX_FORCE] != 0.0:
        px, py, pz = rows[k, EX_POINT], rows[k, EX_POINT + 1], rows[k, EX_POINT + 2]
        return py * vz - pz * vy, pz * vx - px * vz, px * vy - py * vx
    return vx, vy, vz


@njit(cache=True)
def expression_torque(t, y, rows, fn, consts, axes, axes_q, moments):
    """Σ over expression loads active at t of their torque, principal body frame; ``fn`` the
    address of the scene's compiled formulas (``rotlab.scene.formulas``), ``consts`` their
    constants' (``constants_address``).  Called, not inlined into ``rhs``: inlined, it would be typed again at every call
    site, and the formula loads' typing is the largest of all."""
    nx = ny = nz = 0.0
    for k in range(rows.shape[0]):
        if not (rows[k, EX_ON] <= t < rows[k, EX_OFF]):
            continue
        x = expression_inputs(t, y, rows, k, axes, axes_q, moments)
        vx, vy, vz = call_load_formulas(fn, consts, k, x)
        mx, my, mz = expression_output(y, rows, k, axes, vx, vy, vz)
        nx += mx
        ny += my
        nz += mz
    return nx, ny, nz


@njit(cache=True, forceinline=True)
def plus_h_cross_omega(cx, cy, cz, hx, hy, hz, p, q, r):
    """c + h × ω: the gyrostatic torque of rotors' momentum h added to c (body components)."""
    return cx + (hy * r - hz * q), cy + (hz * p - hx * r), cz + (hx * q - hy * p)


def with_gyrostatic(torque, p, q, r, rotors):
    """``torque`` + h × ω for a gyrostat's rotors' momentum h (body frame), workless (ω·(h × ω) = 0);
    ``torque`` itself when there are no rotors (None: compiled to nothing)."""
    raise NotImplementedError("compiled only")


@overload(with_gyrostatic, inline="always")
def _with_gyrostatic(torque, p, q, r, rotors):
    if isinstance(rotors, types.NoneType):
        return lambda torque, p, q, r, rotors: torque

    def impl(torque, p, q, r, rotors):
        return plus_h_cross_omega(torque[0], torque[1], torque[2], rotors[0], rotors[1], rotors[2], p, q, r)

    return impl


def drive_rotors(t, y, dy, c, n, drives):
    """A gyrostat's driven rotors (``rotlab.scene.loads.Drives``): dy[STATE_SIZE + j] = u_j, their
    drives' torques, and (c, n), the conservative and non-conservative body torques (n None: no
    non-conservative load), with the rotors' share added: h(t) × ω to c (workless; h = Σ J Ω_j â_j
    from the state) and −Σ u_j â_j to n (the drives' reaction, which does work).  (c, n) itself
    without driven rotors (None)."""
    raise NotImplementedError("compiled only")


@overload(drive_rotors, inline="always")
def _drive_rotors(t, y, dy, c, n, drives):
    if isinstance(drives, types.NoneType):
        return lambda t, y, dy, c, n, drives: (c, n)

    def impl(t, y, dy, c, n, drives):
        ex = drives.ex
        nx, ny, nz = plus_torque((0.0, 0.0, 0.0), n)  # (n, or 0 without a load that does work: the drives do work)
        cx, cy, cz, nx, ny, nz = rotor_drives(t, y, dy, (c[0], c[1], c[2], nx, ny, nz), ex.rows, ex.fn, constants_address(ex.consts), ex.axes, ex.axes_q,
                                              ex.moments, drives.offset, drives.axes)
        return (cx, cy, cz), (nx, ny, nz)

    return impl


@njit(cache=True)
def rotor_drives(t, y, dy, torques, rows, fn, consts, axes, axes_q, moments, offset, rotor_axes):
    """``drive_rotors`` of the drives' formula rows ``rows`` (programs' loads ``offset`` …) and
    unit axes ``rotor_axes`` (principal frame).  Called, not inlined (a formula's typing is costly)."""
    cx, cy, cz, nx, ny, nz = torques
    p, q, r = y[P0], y[P0 + 1], y[P0 + 2]
    hx = hy = hz = 0.0
    for j in range(rotor_axes.shape[0]):
        u = call_formulas(fn, consts, offset + j, 0, expression_inputs(t, y, rows, j, axes, axes_q, moments))
        dy[STATE_SIZE + j] = u
        h = y[STATE_SIZE + j]
        ax, ay, az = rotor_axes[j, 0], rotor_axes[j, 1], rotor_axes[j, 2]
        hx += h * ax
        hy += h * ay
        hz += h * az
        nx -= u * ax
        ny -= u * ay
        nz -= u * az
    cx, cy, cz = plus_h_cross_omega(cx, cy, cz, hx, hy, hz, p, q, r)
    return cx, cy, cz, nx, ny, nz


_forces_called = njit(cache=True)(forces_torque)
_terms_called = njit(cache=True)(terms_torque)
_tables_called = njit(cache=True)(tables_torque)
_damping_called = njit(cache=True)(damping_torque)


@njit(cache=True)
def torque_at(t, y, model):
    """The torque of all of ``model``'s loads at (t, y), body components: each group's torque as
    the kernels compute it, called (the bench's peers call this from Python, and
    ``torque_samples`` for the recording's load views)."""
    return groups_torque(t, y, model.forces, model.terms, model.tables, model.table_t, model.table_v, model.damping,
                          model.expressions, model.user)


@njit(cache=True)
def groups_torque(t, y, forces, terms, tables, table_t, table_v, damping, ex, user):
    """Σ of the present groups' torques (an absent group is None: its branch is pruned): the
    model's fields one by one, so that a call from Python unboxes only these (the bench's peers)."""
    mx = my = mz = 0.0
    if forces is not None:
        ax, ay, az = _forces_called(y, forces)
        mx, my, mz = mx + ax, my + ay, mz + az
    if terms is not None:
        ax, ay, az = _terms_called(t, y, terms)
        mx, my, mz = mx + ax, my + ay, mz + az
    if tables is not None:
        ax, ay, az = _tables_called(t, y, tables, table_t, table_v)
        mx, my, mz = mx + ax, my + ay, mz + az
    if damping is not None:
        ax, ay, az = _damping_called(y, damping)
        mx, my, mz = mx + ax, my + ay, mz + az
    ax, ay, az = _expressions(t, y, ex)  # (called already: ``expression_torque``)
    mx, my, mz = mx + ax, my + ay, mz + az
    ax, ay, az = _user(t, y, user)
    return mx + ax, my + ay, mz + az


@njit(cache=True)
def torque_samples(t, q, w, model, out):
    """out[k] = ``torque_at`` sample k: time t[k], Λ = q[k], ω = w[k] (principal frame)."""
    y = np.zeros(STATE_SIZE)
    for k in range(t.shape[0]):
        for i in range(4):
            y[Q0 + i] = q[k, i]
        for i in range(3):
            y[P0 + i] = w[k, i]
        out[k, 0], out[k, 1], out[k, 2] = torque_at(t[k], y, model)


@njit(cache=True)
def drive_torques(t, states, model, out):
    """out[k, j] = u_j, driven rotor j's drive torque (N·m) at sample k (time t[k], principal-frame
    state ``states[k]``, the rotors' momenta included)."""
    dy = np.zeros(states.shape[1])
    for k in range(t.shape[0]):
        drive_rotors(t[k], states[k], dy, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), model.drives)
        for j in range(out.shape[1]):
            out[k, j] = dy[STATE_SIZE + j]


# ---- Taylor series of the loads (``rotlab.core.taylor``): coefficients in τ = time − t -----------
# ``nonconservative_series``, ``switch_step`` and ``series_workspace`` are called, not inlined, and
# ``load_series`` is a one-line overload around the compiled ``_time_series`` (one function for
# the terms and the tables, whose absent group numba prunes as a None argument): numba types an
# inlined overload again in its caller, and called, a step costs the same.


def load_series(t, order, model, body, space):
    """body / space (order + 1, 3) ← Taylor coefficients at t of the time-dependent torque terms
    and tables acting on the step from t, body-frame and space-frame ones apart:
    offset + a sin(w τ + φ): a w^k / k! · sin(w t + φ + kπ/2);  a table segment: value, slope."""
    raise NotImplementedError("compiled only")


def nonconservative_series(k, t, X, P, model, body, space, has_space, inputs, tape, stack):
    """Coefficient k of the non-conservative torque (body components) on the step from t, from
    the state's coefficients X[0..k], the products' P[0..k] (λ_i λ_j, ``rotate_quadratic``) and
    the load series of ``load_series``; expressions run in Taylor mode on ``tape``."""
    raise NotImplementedError("compiled only")


def _damping_series(k, X, damping):
    raise NotImplementedError("compiled only")


def _expression_series(k, t, X, P, ex, inputs, tape, stack):
    raise NotImplementedError("compiled only")


@overload(load_series, inline="always")
def _load_series(t, order, model, body, space):
    if all(isinstance(model.types[model.fields.index(group)], types.NoneType) for group in ("terms", "tables")):
        return lambda t, order, model, body, space: None  # no time functions: body, space stay zero
    return lambda t, order, model, body, space: _time_series(t, order, model.terms, model.tables, model.table_t, model.table_v, body, space)


@njit(cache=True)
def _time_series(t, order, terms, tables, table_t, table_v, body, space):
    """``load_series`` of the torque terms and tables (an absent group is None: numba prunes its
    branch for that type)."""
    body[:, :] = 0.0
    space[:, :] = 0.0
    if terms is not None:
        for k in range(terms.shape[0]):
            if not (terms[k, T_ON] <= t < terms[k, T_OFF]):
                continue
            target = space if terms[k, T_FRAME] != 0.0 else body
            for c in range(3):
                target[0, c] += terms[k, T_OFFSET + c]
            w = terms[k, T_W]
            if w != 0.0:
                angle = w * t + terms[k, T_PHASE]
                s, co = np.sin(angle), np.cos(angle)
                scale = 1.0
                for j in range(order + 1):
                    phase = (s, co, -s, -co)[j % 4]  # sin(angle + jπ/2)
                    for c in range(3):
                        target[j, c] += terms[k, T_AMP + c] * scale * phase
                    scale *= w / (j + 1)
    if tables is not None:
        for k in range(tables.shape[0]):
            if not (tables[k, TB_ON] <= t < tables[k, TB_OFF]):
                continue
            lo = table_segment(table_t, int(tables[k, TB_FIRST]), int(tables[k, TB_STOP]), t)
            if lo < 0:
                continue
            target = space if tables[k, TB_FRAME] != 0.0 else body
            dt = table_t[lo + 1] - table_t[lo]
            for c in range(3):
                slope = (table_v[lo + 1, c] - table_v[lo, c]) / dt
                target[0, c] += table_v[lo, c] + slope * (t - table_t[lo])
                if order >= 1:
                    target[1, c] += slope


@overload(nonconservative_series)
def _nonconservative_series(k, t, X, P, model, body, space, has_space, inputs, tape, stack):
    def impl(k, t, X, P, model, body, space, has_space, inputs, tape, stack):
        dx, dy, dz = _damping_series(k, X, model.damping)
        ex, ey, ez = _expression_series(k, t, X, P, model.expressions, inputs, tape, stack)
        nx = body[k, 0] + dx + ex
        ny = body[k, 1] + dy + ey
        nz = body[k, 2] + dz + ez
        if has_space:
            nx += space[k, 0]
            ny += space[k, 1]
            nz += space[k, 2]
            for j in range(k + 1):
                lx, ly, lz = rotate_quadratic(P, N_PRODUCTS * j, space[k - j, 0], space[k - j, 1], space[k - j, 2])
                nx += lx
                ny += ly
                nz += lz
        return nx, ny, nz

    return impl


@overload(_damping_series, inline="always")
def _damping_series_impl(k, X, damping):
    if isinstance(damping, types.NoneType):
        return lambda k, X, damping: (0.0, 0.0, 0.0)
    return lambda k, X, damping: (-damping * X[k, P0], -damping * X[k, P0 + 1], -damping * X[k, P0 + 2])


@overload(_expression_series, inline="always")
def _expression_series_impl(k, t, X, P, ex, inputs, tape, stack):
    if isinstance(ex, types.NoneType):
        return lambda k, t, X, P, ex, inputs, tape, stack: (0.0, 0.0, 0.0)

    def impl(k, t, X, P, ex, inputs, tape, stack):
        return expression_series(k, t, X, P, ex.rows, ex.code, ex.consts, ex.axes, ex.axes_q, ex.moments, inputs, tape, stack)

    return impl


@njit(cache=True)
def _check_series(k, t, X, tape, rx, ry, rz, load, axes, axes_q):
    """Record a fault (``rotlab.core.faults``) when coefficient k of a component of expression load
    ``load`` is not finite while its inputs' coefficients X[k] and the state at the step's start
    are: the formula is not finite (k = 0) or has no Taylor series (k ≥ 1: not smooth) at t.
    (An X[k] that is not finite came from another load's earlier coefficient, the fault already
    recorded.)  The order k is the detail."""
    for m in range(P0 + 3):
        if not math.isfinite(X[k, m]):
            return
    for c in range(3):
        row = rx if c == 0 else (ry if c == 1 else rz)
        if math.isfinite(tape[row, k]) or (k > 0 and not math.isfinite(tape[row, 0])):  # (order 0 said it)
            continue
        w0, w1, w2 = _to_user(axes, X[0, P0], X[0, P0 + 1], X[0, P0 + 2])
        q0, q1, q2, q3 = _to_user_quaternion(axes_q, X[0, Q0], X[0, Q0 + 1], X[0, Q0 + 2], X[0, Q0 + 3])
        record(FORMULA_NOT_FINITE, load, c, t, w0, w1, w2, q0, q1, q2, q3, float(k))
        return


def switch_step(t, model, tape, order, h):
    """h, shortened so that the step from t ends just past the first switch of an abs, sign,
    min or max of an active expression load; −1 when the series must be formed again with a
    switch's other side (``rotlab.core.expressions.switch_limit``)."""
    raise NotImplementedError("compiled only")


@overload(switch_step)
def _switch_step(t, model, tape, order, h):
    ex_type = model.types[model.fields.index("expressions")]
    if isinstance(ex_type, types.NoneType):
        return lambda t, model, tape, order, h: h

    def impl(t, model, tape, order, h):
        ex = model.expressions
        cut = h
        for r in range(ex.rows.shape[0]):
            row = ex.rows[r]
            if row[EX_ON] <= t < row[EX_OFF]:
                limit = switch_limit(ex.code, int(row[EX_PROGRAMS]), int(row[EX_PROGRAMS + 5]), tape, order, h)
                cut = -1.0 if (limit < 0.0 or cut < 0.0) else min(cut, limit)
        return cut

    return impl


def series_workspace(model, order):
    """(inputs, tape, stack) for ``nonconservative_series`` at ``order`` (empty without expressions)."""
    raise NotImplementedError("compiled only")


@overload(series_workspace)
def _series_workspace(model, order):
    ex_type = model.types[model.fields.index("expressions")]
    if isinstance(ex_type, types.NoneType):
        return lambda model, order: (np.zeros(0), np.zeros((0, order + 1)), np.zeros(0, dtype=np.int64))

    def impl(model, order):
        ex = model.expressions
        return (np.zeros(N_INPUTS), np.zeros((ex.code.shape[0] + ex.aux, order + 1)),
                np.zeros(max(ex.depth, 1), dtype=np.int64))

    return impl


@njit(cache=True)
def expression_series(k, t, X, P, rows, code, consts, axes, axes_q, moments, inputs, tape, stack):
    """Coefficient k of the torque of the expression loads active at t (body components): the
    inputs' coefficients (``expression_inputs`` term by term: linear maps of X[k], γ from
    (Rᵀ u)^[k] = u^[k] + Σ_j L(P^[j], u^[k−j]) with u(τ) = up(t + τ)), then the programs in
    Taylor mode; a space-frame result is rotated the same way."""
    nx = ny = nz = 0.0
    for r in range(rows.shape[0]):
        row = rows[r]
        if not (row[EX_ON] <= t < row[EX_OFF]):
            continue
        inputs[0] = t if k == 0 else (1.0 if k == 1 else 0.0)
        inputs[1], inputs[2], inputs[3] = _to_user(axes, X[k, P0], X[k, P0 + 1], X[k, P0 + 2])
        l0, l1, l2, l3 = X[k, Q0], X[k, Q0 + 1], X[k, Q0 + 2], X[k, Q0 + 3]
        inputs[4], inputs[5], inputs[6], inputs[7] = _to_user_quaternion(axes_q, l0, l1, l2, l3)
        gx = gy = gz = 0.0
        for j in range(k + 1):  # Rᵀ u = u + L(P, u), u^[m] = ν^m/m! (cos(νt + mπ/2) a + sin(νt + mπ/2) b)
            m = k - j
            ux, uy, uz = _up_coefficient(row, t, m)
            if j == 0:
                gx, gy, gz = ux, uy, uz
            lx, ly, lz = rotate_quadratic(P, N_PRODUCTS * j, ux, uy, uz)
            gx += lx
            gy += ly
            gz += lz
        inputs[8], inputs[9], inputs[10] = _to_user(axes, gx, gy, gz)
        inputs[11], inputs[12], inputs[13] = _to_user(axes, moments[0] * X[k, P0], moments[1] * X[k, P0 + 1], moments[2] * X[k, P0 + 2])
        p = EX_PROGRAMS
        rx = series_step(code, consts, int(row[p]), int(row[p + 1]), k, inputs, tape, stack)
        ry = series_step(code, consts, int(row[p + 2]), int(row[p + 3]), k, inputs, tape, stack)
        rz = series_step(code, consts, int(row[p + 4]), int(row[p + 5]), k, inputs, tape, stack)
        _check_series(k, t, X, tape, rx, ry, rz, r, axes, axes_q)
        if row[EX_FRAME] != 0.0:
            vx, vy, vz = tape[rx, k], tape[ry, k], tape[rz, k]
            for j in range(k + 1):
                lx, ly, lz = rotate_quadratic(P, N_PRODUCTS * j, tape[rx, k - j], tape[ry, k - j], tape[rz, k - j])
                vx += lx
                vy += ly
                vz += lz
        else:
            vx, vy, vz = _to_principal(axes, tape[rx, k], tape[ry, k], tape[rz, k])
        if row[EX_FORCE] != 0.0:
            px, py, pz = row[EX_POINT], row[EX_POINT + 1], row[EX_POINT + 2]
            vx, vy, vz = py * vz - pz * vy, pz * vx - px * vz, px * vy - py * vx
        nx += vx
        ny += vy
        nz += vz
    return nx, ny, nz


@njit(cache=True, forceinline=True)
def _up_coefficient(row, t, m):
    """Coefficient m of up(t + τ) = cos(ν(t + τ)) a + sin(ν(t + τ)) b."""
    nu = row[EX_RATE]
    if nu == 0.0:
        if m == 0:
            return row[EX_UP], row[EX_UP + 1], row[EX_UP + 2]
        return 0.0, 0.0, 0.0
    scale = 1.0
    for j in range(1, m + 1):
        scale *= nu / j
    angle = nu * t + 0.5 * np.pi * m
    c, s = scale * np.cos(angle), scale * np.sin(angle)
    return (c * row[EX_UP] + s * row[EX_UP2], c * row[EX_UP + 1] + s * row[EX_UP2 + 1], c * row[EX_UP + 2] + s * row[EX_UP2 + 2])
