"""Pydantic v2 models of a scenario file.  Units SI; angles in radians unless a key ends in
``_deg``.  Every vector names its frame in the key's documentation; unknown keys are errors.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Mapping, Self, Union

import numpy as np
from pydantic import (
    Discriminator,
    Tag,
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from rotlab import geometry_inertia, inertia, invariants
from rotlab.config import expressions
from rotlab.core import quaternion as quat
from rotlab.errors import InputError
from rotlab.method_names import METHOD_NAMES

MAX_SAMPLES = 1_000_000_000  # a sanity bound; long runs are streamed, and [output] max_megabytes asks first
QUATERNION_NORM_TOLERANCE = 1e-3
# Ranges that keep every product the kernels form (I ω², m g r, k ω, ...) finite in float64.
MAX_MAGNITUDE = 1e30
MIN_POSITIVE = 1e-30
# The recording's time axis holds int64 nanoseconds: |t| ≤ 9.2e9 s, resolution 1 ns.
MAX_TIME = 9e9  # s
TIME_RESOLUTION = 1e-9  # s
MIN_RTOL = 1e-16  # below double precision's resolution no method can go


def _real(value: object) -> object:
    """Accept TOML integers and floats only (no strings, no booleans), finite and of magnitude
    at most ``MAX_MAGNITUDE``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PydanticCustomError("real_number", "must be a number, found {found}", {"found": repr(value)})
    try:
        number = float(value)
    except OverflowError:  # a TOML integer beyond the float range
        number = math.inf
    if not math.isfinite(number):
        raise PydanticCustomError("finite_number", "must be a finite number, found {found}", {"found": repr(value)[:40]})
    if abs(number) > MAX_MAGNITUDE:
        raise PydanticCustomError(
            "magnitude", "must be at most 1e30 in magnitude (found {found}): use SI units of a real body", {"found": f"{number:g}"}
        )
    return number


def _positive(value: float) -> float:
    if not value > 0.0:
        raise PydanticCustomError("positive", "must be > 0 (found {found})", {"found": f"{value:g}"})
    if value < MIN_POSITIVE:
        raise PydanticCustomError("positive", "must be at least 1e-30 (found {found}): use SI units of a real body", {"found": f"{value:g}"})
    return value


def _rtol(value: float) -> float:
    if not MIN_RTOL <= value <= 1.0:
        raise PydanticCustomError(
            "rtol", "must be between 1e-16 and 1 (found {found}): double precision resolves no finer", {"found": f"{value:g}"}
        )
    return value


def _time(value: float) -> float:
    if abs(value) > MAX_TIME:
        raise PydanticCustomError(
            "time_range",
            "must be within ±9e9 s (found {found}): the recording's time axis holds int64 nanoseconds",
            {"found": f"{value:g}"},
        )
    return value


def _invalid(key: str | tuple[str, ...], message: str) -> PydanticCustomError:
    """A semantic error attached to sub-key ``key`` of the model being validated (dotted, or a
    tuple of parts where a part holds dots: a sweep parameter's name)."""
    return PydanticCustomError("rotlab", message.replace("{", "(").replace("}", ")"), {"key": key})


class _SchemaBounds:
    """The bounds a validator above enforces, stated in the JSON Schema too (``rotlab schema``):
    editors then flag the value as the loader would.  Enforcement stays with the validator, whose
    message names the fix."""

    def __init__(self, **bounds: float) -> None:
        self.bounds = bounds

    def __get_pydantic_json_schema__(self, core_schema: Any, handler: Any) -> dict[str, Any]:
        schema = handler(core_schema)
        schema.update(self.bounds)
        return schema


Real = Annotated[float, BeforeValidator(_real), _SchemaBounds(minimum=-MAX_MAGNITUDE, maximum=MAX_MAGNITUDE)]
PositiveReal = Annotated[float, BeforeValidator(_real), AfterValidator(_positive),
                         _SchemaBounds(minimum=MIN_POSITIVE, maximum=MAX_MAGNITUDE)]
TimeReal = Annotated[float, BeforeValidator(_real), AfterValidator(_time), _SchemaBounds(minimum=-MAX_TIME, maximum=MAX_TIME)]  # s, an instant
NonNegativeReal = Annotated[float, BeforeValidator(_real), Field(ge=0), _SchemaBounds(minimum=0.0, maximum=MAX_MAGNITUDE)]
MomentReal = Annotated[float, BeforeValidator(_real), _SchemaBounds(minimum=MIN_POSITIVE, maximum=MAX_MAGNITUDE)]  # Body checks > 0
Vec3 = tuple[Real, Real, Real]
Vec4 = tuple[Real, Real, Real, Real]
Frame = Literal["body", "space"]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)

    def model_copy(self, *, update: Mapping[str, Any] | None = None, deep: bool = False) -> Self:
        """A copy with ``update`` applied and validated like the file (pydantic's own
        ``model_copy`` skips validation: ``mass = -1`` would pass)."""
        copied = super().model_copy(update=update, deep=deep)
        if not update:
            return copied
        try:
            return type(self).model_validate(copied.model_dump(mode="json", exclude_unset=True))
        except ValidationError as exc:
            first = exc.errors(include_url=False)[0]
            key = ".".join(str(part) for part in (*first["loc"], *((first.get("ctx") or {}).get("key", ()),)) if part)
            raise InputError(f"{type(self).__name__}.model_copy: {key}", first["msg"].replace("Value error, ", "")) from None


class Window(_Model):
    """On/off time window [on, off) in seconds; the load acts only inside it."""

    on: TimeReal = -math.inf
    off: TimeReal = math.inf

    @model_validator(mode="after")
    def _ordered(self) -> Window:
        if not self.on < self.off:
            raise _invalid("off", f"window must have on < off (got on = {self.on:g}, off = {self.off:g})")
        if self.off - self.on < TIME_RESOLUTION:
            raise _invalid("off", f"window is {self.off - self.on:.3g} s long, shorter than the 1 ns time resolution: widen it")
        return self


class BoxShape(_Model):
    box: tuple[PositiveReal, PositiveReal, PositiveReal]  # m, edge lengths along x, y, z


class CylinderSize(_Model):
    radius: PositiveReal  # m
    length: PositiveReal  # m, along z


class CylinderShape(_Model):
    cylinder: CylinderSize


class SphereShape(_Model):
    sphere: PositiveReal  # m, radius (solid)


class DiscSize(_Model):
    radius: PositiveReal  # m, thin, in the x–y plane


class DiscShape(_Model):
    disc: DiscSize


class RodShape(_Model):
    rod: PositiveReal  # m, length along z (thin)


class PointShape(_Model):
    point: Literal[True]  # a point mass


_SHAPES = {"box": BoxShape, "cylinder": CylinderShape, "sphere": SphereShape, "disc": DiscShape, "rod": RodShape, "point": PointShape}


def _shape(value: object) -> object:
    """A one-key table naming the shape (``rotlab.geometry_inertia``)."""
    if isinstance(value, dict) and len(value) == 1 and next(iter(value)) in _SHAPES:
        return _SHAPES[next(iter(value))].model_validate(value)
    if isinstance(value, BaseModel):
        return value
    raise PydanticCustomError(
        "rotlab", "must be one of { box = [a, b, c] }, { cylinder = { radius = r, length = L } }, { sphere = r }, "
        "{ disc = { radius = r } }, { rod = L }, { point = true } (m; found {found})", {"found": repr(value)[:40]})


Shape = Annotated[Union[BoxShape, CylinderShape, SphereShape, DiscShape, RodShape, PointShape], BeforeValidator(_shape)]


def shape_kind(shape: BaseModel) -> tuple[str, object]:
    """(kind, size) of a shape model, as ``rotlab.geometry_inertia.central_inertia`` takes them."""
    kind = next(iter(type(shape).model_fields))
    size = getattr(shape, kind)
    return kind, size.model_dump() if isinstance(size, BaseModel) else size


class Part(_Model):
    """One part of a composite body: a uniform shape (or a point mass) with its own axes parallel
    to the body's, its centre at ``center`` (m, in the body description's frame)."""

    shape: Shape
    mass: PositiveReal  # kg
    center: Vec3 = (0.0, 0.0, 0.0)  # m


class Body(_Model):
    """Rigid body.  Inertia about the FIXED POINT, in the body frame (the frame you give it in);
    or its geometry (``shape`` and ``mass``, or ``parts``) and the fixed point ``pivot``, from
    which rotlab computes both (``rotlab.geometry_inertia``; the body frame: the shape's axes,
    origin at the pivot)."""

    principal_moments: tuple[MomentReal, MomentReal, MomentReal] | None = None  # (A, B, C) kg·m², body axes are principal axes
    inertia_tensor: tuple[Vec3, Vec3, Vec3] | None = None  # kg·m², symmetric positive definite
    shape: Shape | None = None  # a uniform solid, with ``mass``: its own axes are the body axes
    parts: list[Part] | None = None  # a composite: each a shape (or point), mass and centre
    pivot: Vec3 = (0.0, 0.0, 0.0)  # m: the fixed point, from the shape's centre (or in the parts' frame)
    mass: PositiveReal | None = None  # kg
    center_of_mass: Vec3 = (0.0, 0.0, 0.0)  # m, body frame, from the fixed point
    allow_triangle_violation: bool = False  # opt-in for mathematical test problems only

    def geometry(self) -> tuple[np.ndarray, np.ndarray, float] | None:
        """(inertia about the fixed point (kg·m²), centre of mass from it (m), mass (kg)) of a body
        given by its geometry; None for one given by its moments."""
        if self.shape is not None:
            parts = [(*shape_kind(self.shape), float(self.mass or 0.0), np.zeros(3))]
        elif self.parts is not None:
            parts = [(*shape_kind(p.shape), p.mass, np.asarray(p.center, dtype=float)) for p in self.parts]
        else:
            return None
        return geometry_inertia.about_pivot(parts, np.asarray(self.pivot, dtype=float))

    def tensor(self) -> np.ndarray:
        """The inertia tensor about the fixed point, body frame (kg·m²)."""
        if self.principal_moments is not None:
            return np.diag(np.asarray(self.principal_moments, dtype=float))
        computed = self.geometry()
        return np.asarray(self.inertia_tensor, dtype=float) if computed is None else computed[0]

    def centre(self) -> tuple[float, float, float]:
        """The centre of mass from the fixed point, body frame (m)."""
        computed = self.geometry()
        return self.center_of_mass if computed is None else tuple(float(x) for x in computed[1])  # type: ignore[return-value]

    def total_mass(self) -> float | None:
        """The mass (kg; None when not given)."""
        computed = self.geometry()
        return self.mass if computed is None else computed[2]

    @model_validator(mode="after")
    def _physical(self) -> Body:
        given = [k for k in ("principal_moments", "inertia_tensor", "shape", "parts") if getattr(self, k) is not None]
        if len(given) != 1:
            raise _invalid(
                given[1] if given else "principal_moments",
                "give exactly one of principal_moments = [A, B, C], inertia_tensor = [[...], [...], [...]], "
                "shape = { box = [a, b, c] } (with mass) or [[body.parts]]",
            )
        if given[0] in ("shape", "parts"):
            self._check_geometry(given[0])
            key = given[0]
            moments, _ = inertia.principal_axes(self.tensor())
            if moments[0] <= 0.0:
                raise _invalid(key, f"the body has no inertia about an axis (principal moments {moments.tolist()}): a rod or "
                                    "points on one line through the pivot: add a part off that line")
        elif "pivot" in self.model_fields_set:
            raise _invalid("pivot", "pivot places the fixed point in a shape or its parts: with moments of inertia, the fixed point is the origin")
        elif self.principal_moments is not None:
            key = "principal_moments"
            moments = self.principal_moments  # three floats: plain Python (NumPy's overhead on 3 numbers shows in a sweep case)
            if any(m <= 0.0 for m in moments):
                raise _invalid(key, f"moments of inertia must be > 0 kg·m² (got {list(self.principal_moments)})")
        else:
            key = "inertia_tensor"
            tensor = np.array(self.inertia_tensor)
            if inertia.asymmetry(tensor) > inertia.SYMMETRY_RTOL:
                raise _invalid(key, "tensor is not symmetric: I[i][j] must equal I[j][i]")
            moments, _ = inertia.principal_axes(tensor)
            if moments[0] <= 0.0:
                raise _invalid(
                    key, f"tensor is not positive definite (principal moments {moments.tolist()}): check signs of products of inertia"
                )
        if min(moments) < MIN_POSITIVE:
            raise _invalid(key, f"principal moments must be at least 1e-30 kg·m² (got {np.asarray(moments).tolist()}): use SI units of a real body")
        broken = inertia.triangle_violation(moments)
        if broken and not self.allow_triangle_violation:
            raise _invalid(
                key,
                f"principal moments break the triangle inequality, {broken}: no real body has them; "
                "set allow_triangle_violation = true for a mathematical test problem",
            )
        spread = inertia.moment_ratio_violation(moments)
        if spread:
            raise _invalid(key, f"{spread}: no real body has them, and the equations of motion lose all precision; check the units")
        if self.mass is not None and not self.allow_triangle_violation and any(self.center_of_mass):
            self._check_centre_of_mass()
        return self

    def _check_geometry(self, key: str) -> None:
        """A geometry gives the mass and the centre of mass: they are not given too."""
        if key == "shape" and self.mass is None:
            raise _invalid("mass", "a shape needs its mass: add mass = ... (kg) under [body]")
        if key == "parts" and self.mass is not None:
            raise _invalid("mass", "the parts carry their masses: remove body.mass (the total is their sum)")
        if key == "parts" and not self.parts:
            raise _invalid("parts", "give at least one part")
        if "center_of_mass" in self.model_fields_set:
            raise _invalid("center_of_mass", f"computed from the {key}: remove center_of_mass (the fixed point is pivot)")

    def _check_centre_of_mass(self) -> None:
        """The inertia about the centre of mass must be realisable (``rotlab.inertia``)."""
        tensor = self.inertia_tensor or [[self.principal_moments[i] if i == j else 0.0 for j in range(3)] for i in range(3)]
        why = inertia.centre_of_mass_violation(tensor, self.mass, self.center_of_mass)
        if why:
            arm = math.sqrt(sum(x * x for x in self.center_of_mass))
            raise _invalid(
                "center_of_mass",
                f"no body has these moments of inertia about the fixed point with {self.mass:g} kg at {arm:g} m from it "
                f"(m r² = {self.mass * arm * arm:.3g} kg·m²; {why}): is the mass in kg, not grams, and the centre of mass "
                "in m and not too far out? (set allow_triangle_violation = true for a mathematical test problem)",
            )


# keys that give one quantity (in several units, or several ways): a --set of one replaces the
# file's others (``loader``); the model holds one of each group
ONE_QUANTITY = ({"omega", "omega_rpm", "omega_deg"},
                {"quaternion", "axis_angle", "axis_angle_deg", "euler_313", "euler_313_deg"},
                {"target", "target_euler_313_deg", "target_axis_angle_deg"},
                {"spin", "spin_rpm", "momentum"},
                {"sample_rate", "samples"})
RPM = 2.0 * math.pi / 60.0  # rad/s per revolution per minute
DEGREE = math.pi / 180.0  # rad per degree


def _three_numbers(key: str, value: object) -> list[float]:
    if not (isinstance(value, (list, tuple)) and len(value) == 3):
        raise _invalid(key, f"must be three numbers [x, y, z] (found {repr(value)[:40]})")
    out = []
    for k, v in enumerate(value):
        try:
            out.append(float(_real(v)))
        except PydanticCustomError as exc:
            raise _invalid(f"{key}.{k}", exc.message()) from None
    return out


def _in_other_units(data: object, conversions: dict[str, tuple[str, Any]]) -> object:
    """A table's keys given in other units (``omega_rpm`` …), replaced before validation by the
    key the model holds, converted (``conversions``: other key → (own key, convert(three
    numbers))): the scenario then holds one value, in SI units, whichever way it was written."""
    if not isinstance(data, dict):
        return data
    out = dict(data)
    for other, (own, convert) in conversions.items():
        if other not in out:
            continue
        if own in out:
            raise _invalid(other, f"give {own} or {other}, not both")
        out[own] = convert(_three_numbers(other, out.pop(other)))
    return out


class Initial(_Model):
    """Initial state.  ω in BODY components; orientation maps body → space (default: identity).
    ``omega_rpm`` (rev/min) or ``omega_deg`` (deg/s) may give ω, ``axis_angle_deg`` the rotation
    vector in degrees: each is stored converted, as ``omega`` and ``axis_angle``."""

    @model_validator(mode="before")
    @classmethod
    def _units(cls, data: object) -> object:
        return _in_other_units(data, {"omega_rpm": ("omega", lambda v: [x * RPM for x in v]),
                                      "omega_deg": ("omega", lambda v: [x * DEGREE for x in v]),
                                      "axis_angle_deg": ("axis_angle", lambda v: [x * DEGREE for x in v])})

    # other units, stored converted (the model never holds them: ``_in_other_units``); in the JSON Schema for editors
    omega_rpm: Vec3 | None = None  # rev/min, body frame
    omega_deg: Vec3 | None = None  # deg/s, body frame
    axis_angle_deg: Vec3 | None = None  # rotation vector, degrees
    omega: Vec3 = (0.0, 0.0, 0.0)  # rad/s, body frame
    quaternion: Vec4 | None = None  # scalar first (q0, q1, q2, q3)
    axis_angle: Vec3 | None = None  # rotation vector: axis × angle (rad), space = body at angle 0
    euler_313: Vec3 | None = None  # (ψ, θ, φ) rad, classical 3-1-3
    euler_313_deg: Vec3 | None = None  # (ψ, θ, φ) degrees

    @model_validator(mode="after")
    def _one_orientation(self) -> Initial:
        given = [k for k in ("quaternion", "axis_angle", "euler_313", "euler_313_deg") if getattr(self, k) is not None]
        if len(given) > 1:
            raise _invalid(given[1], f"give only one orientation, found {', '.join(given)}")
        if self.quaternion is not None:
            _unit_quaternion("quaternion", self.quaternion)
        return self


class Gravity(_Model):
    """Uniform field acting on body.mass at body.center_of_mass: M = r_c × (m Rᵀ g)."""

    type: Literal["gravity"]
    g: Vec3 = (0.0, 0.0, -9.81)  # m/s², SPACE frame


class Torque(_Model):
    """Constant torque M (N·m) in the named frame; body = follower load, space = fixed direction."""

    type: Literal["torque"]
    frame: Frame
    value: Vec3
    window: Window | None = None


class Force(_Model):
    """Constant force F (N) in the named frame, applied at a body point (m, body frame)."""

    type: Literal["force"]
    frame: Frame
    value: Vec3
    point: Vec3
    window: Window | None = None  # a windowed space-frame force does work (no potential)


class HarmonicTorque(_Model):
    """M(t) = offset + amplitude · sin(angular_frequency · t + phase), in the named frame."""

    type: Literal["harmonic_torque"]
    frame: Frame
    amplitude: Vec3  # N·m
    angular_frequency: Real  # rad/s
    phase: Real = 0.0  # rad
    offset: Vec3 = (0.0, 0.0, 0.0)  # N·m
    window: Window | None = None


class TorqueTable(_Model):
    """Piecewise-linear torque through (times[k], values[k]); zero outside [times[0], times[-1]]."""

    type: Literal["torque_table"]
    frame: Frame
    times: tuple[TimeReal, ...]  # s, strictly increasing (tuples: a frozen load is hashable)
    values: tuple[Vec3, ...]  # N·m
    window: Window | None = None

    @model_validator(mode="after")
    def _table(self) -> TorqueTable:
        if len(self.times) < 2:
            raise _invalid("times", "a table needs at least 2 points")
        if len(self.values) != len(self.times):
            raise _invalid("values", f"needs one [Mx, My, Mz] per time: {len(self.times)} times, {len(self.values)} values")
        if np.any(np.diff(self.times) <= 0.0):
            raise _invalid("times", "times must be strictly increasing")
        if np.any(np.diff(self.times) < TIME_RESOLUTION):
            raise _invalid("times", "times closer than the 1 ns time resolution: merge those points")
        return self


class Damping(_Model):
    """Linear damping torque M = −k ω (N·m·s); the same vector in every frame."""

    type: Literal["damping"]
    coefficient: NonNegativeReal


def _unit_quaternion(key: str, value: tuple[float, ...]) -> None:
    norm = float(np.linalg.norm(value))
    if norm == 0.0:
        raise _invalid(key, "zero quaternion has no orientation: use [1, 0, 0, 0] for the identity")
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise _invalid(key, f"|Λ| = {norm:.6g} is not 1: give a unit quaternion (divide each component by {norm:.6g})")


Formula3 = tuple[str, str, str]


def _check_formula_inputs(up: tuple[float, float, float], constants: dict[str, float]) -> None:
    """What formulas read besides the state: ``up`` (the direction gamma shows) and the names of ``constants``."""
    if float(np.linalg.norm(up)) == 0.0:
        raise _invalid("up", "up must be a non-zero direction (space frame)")
    for name in constants:
        try:
            expressions.check_constant_name(name)
        except expressions.FormulaError as exc:
            raise _invalid(f"constants.{name}", exc.message) from None


class Expression(_Model):
    """Torque, or force at a body point, whose components are formulas (``rotlab.config.expressions``)
    of t, omega (body), q (Λ), gamma (``up`` in body components), L (body) and ``constants``;
    the result is in the named frame (N·m or N)."""

    type: Literal["expression"]
    frame: Frame
    torque: Formula3 | None = None  # N·m
    force: Formula3 | None = None  # N, applied at ``point``
    point: Vec3 | None = None  # m, body frame
    constants: dict[str, Real] = {}
    up: Vec3 = (0.0, 0.0, 1.0)  # space frame: the direction gamma shows in body components
    window: Window | None = None

    @model_validator(mode="after")
    def _formulas(self) -> Expression:
        if (self.torque is None) == (self.force is None):
            raise _invalid("torque", "give exactly one of torque = [\"Mx\", \"My\", \"Mz\"] or force = [...] with point = [x, y, z]")
        if (self.force is None) != (self.point is None):
            raise _invalid("point", "a force needs point = [x, y, z] (m, body frame), and a torque takes no point")
        _check_formula_inputs(self.up, self.constants)
        self.programs()
        return self

    def programs(self) -> list[tuple[expressions.Program, int]]:
        """The three components' (program, stack depth)."""
        key = "torque" if self.torque is not None else "force"
        out = []
        for k, text in enumerate(self.torque if self.torque is not None else self.force):  # type: ignore[union-attr]
            try:
                out.append(expressions.parse_formula(text, self.constants))
            except expressions.FormulaError as exc:
                raise _invalid(f"{key}.{k}", str(exc)) from None
        return out


class PDControl(_Model):
    """Attitude controller toward ``target``: M = sat(−kp sgn(δ₀) δ_v − kd ω) in the body frame,
    δ = Λ_target⁻¹ ∘ Λ (δ_v its vector part, sin of half the error angle times the axis),
    each component clipped to ±max_torque."""

    type: Literal["pd_control"]
    target: Vec4 = (1.0, 0.0, 0.0, 0.0)  # body → space, scalar first
    target_euler_313_deg: Vec3 | None = None  # or the target as 3-1-3 angles (ψ, θ, φ), degrees: stored as ``target``
    target_axis_angle_deg: Vec3 | None = None  # or as a rotation vector, degrees: stored as ``target``
    kp: NonNegativeReal  # N·m (per unit of δ_v)
    kd: NonNegativeReal  # N·m·s
    max_torque: PositiveReal | None = None  # N·m per component
    window: Window | None = None

    @model_validator(mode="before")
    @classmethod
    def _units(cls, data: object) -> object:
        return _in_other_units(data, {
            "target_euler_313_deg": ("target", lambda v: quat.from_euler_313(*(x * DEGREE for x in v)).tolist()),
            "target_axis_angle_deg": ("target", lambda v: (quat.from_axis_angle(np.asarray(v), DEGREE * float(np.linalg.norm(v)))
                                                           if any(v) else np.array([1.0, 0.0, 0.0, 0.0])).tolist())})

    @model_validator(mode="after")
    def _target(self) -> PDControl:
        _unit_quaternion("target", self.target)
        return self


class GravityGradient(_Model):
    """Gravity-gradient torque of a circular orbit, M = 3 n² γ × (I γ) in the body frame, γ the
    local vertical in body components.  The vertical turns (Earth-pointing orbit frame) about
    ``orbit_normal`` at the orbit rate n: up(t) = cos(n t) vertical + sin(n t) normal × vertical."""

    type: Literal["gravity_gradient"]
    orbit_rate: PositiveReal  # n, rad/s
    vertical: Vec3 = (1.0, 0.0, 0.0)  # space frame: local vertical at t = 0
    orbit_normal: Vec3 = (0.0, 0.0, 1.0)  # space frame, perpendicular to vertical

    @model_validator(mode="after")
    def _orbit(self) -> GravityGradient:
        v, h = np.asarray(self.vertical), np.asarray(self.orbit_normal)
        if np.linalg.norm(v) == 0.0 or np.linalg.norm(h) == 0.0:
            raise _invalid("vertical", "vertical and orbit_normal must be non-zero directions")
        if abs(float(v @ h)) > 1e-9 * float(np.linalg.norm(v) * np.linalg.norm(h)):
            raise _invalid("orbit_normal", "orbit_normal must be perpendicular to vertical")
        return self


class QuadraticDrag(_Model):
    """Quadratic (aerodynamic) drag torque M = −c |ω| ω (N·m·s²); the same vector in every frame."""

    type: Literal["quadratic_drag"]
    coefficient: NonNegativeReal
    window: Window | None = None


class _Orbit(_Model):
    """A circular orbit in Earth's tilted-dipole field (``rotlab.scene.geomagnetic``)."""

    altitude: PositiveReal = 500e3  # m
    inclination_deg: Real = 51.6  # degrees
    tilt_deg: Real = 11.5  # degrees: the dipole's tilt from Earth's axis
    field: PositiveReal = 3.12e-5  # T: the dipole's field on the surface at the magnetic equator


class MagneticDipole(_Orbit):
    """A constant magnetic dipole m fixed in the body (residual magnetism, or a torquer held on):
    M = m × B, B Earth's field along the orbit in body components."""

    type: Literal["magnetic_dipole"]
    dipole: Vec3  # A·m², body frame
    window: Window | None = None


class BDotDetumbling(_Orbit):
    """Magnetorquers along the body axes driven by the B-dot law m = −k dB/dt, with the rate of B
    seen in the body taken as −ω × B (the body's tumbling dominates the orbit's rate): m = k ω × B,
    each component clipped to ±max_dipole; M = m × B.  M·ω = −m·(ω × B) ≤ 0: it only takes energy out."""

    type: Literal["bdot_detumbling"]
    gain: PositiveReal  # k, A·m² per (rad/s · T)
    max_dipole: PositiveReal  # A·m² per torquer (body axis)
    window: Window | None = None


LOAD_KINDS = (Gravity, Torque, Force, HarmonicTorque, TorqueTable, Damping, Expression, PDControl, GravityGradient, QuadraticDrag,
              MagneticDipole, BDotDetumbling)
Load = Annotated[Union[LOAD_KINDS], Field(discriminator="type")]  # type: ignore[valid-type]
LOAD_MODELS: dict[str, type[_Model]] = {
    m.model_fields["type"].annotation.__args__[0]: m  # type: ignore[union-attr]
    for m in LOAD_KINDS
}


EVENT_NAME_LENGTH = 40


class Event(_Model):
    """An event: where the formula ``when`` (the grammar of expression loads, ``up`` the direction
    gamma shows) crosses 0 in ``direction``, located on the method's own local solution
    (``rotlab.events``).  ``record``: formulas whose values are kept at each occurrence (a
    Poincaré section); ``terminal``: the run stops at the ``count``-th occurrence."""

    name: str
    when: str
    direction: Literal["rising", "falling", "both"] = "both"
    terminal: bool = False
    count: Annotated[int, Field(ge=1, strict=True)] = 1  # the occurrence a terminal event stops at
    record: list[str] = []
    constants: dict[str, Real] = {}
    up: Vec3 = (0.0, 0.0, 1.0)  # space frame: the direction gamma shows in body components

    @model_validator(mode="after")
    def _valid(self) -> Event:
        if not (self.name.isascii() and self.name.isidentifier() and len(self.name) <= EVENT_NAME_LENGTH):
            raise _invalid("name", f"event name {self.name!r} must be a plain identifier (letters, digits, _) of at most "
                                   f"{EVENT_NAME_LENGTH} characters: it names the event's columns and recording path")
        if not self.terminal and "count" in self.model_fields_set:
            raise _invalid("count", "count applies to a terminal event: set terminal = true or remove count")
        _check_formula_inputs(self.up, self.constants)
        self.programs()
        return self

    def programs(self) -> list[tuple[expressions.Program, int]]:
        """(program, stack depth) of ``when``, then of each ``record`` formula."""
        out = []
        for key, text in [("when", self.when), *((f"record.{k}", r) for k, r in enumerate(self.record))]:
            try:
                out.append(expressions.parse_formula(text, self.constants))
            except expressions.FormulaError as exc:
                raise _invalid(key, str(exc)) from None
        return out


DRIVE_TAGS = ("formula", "pd_control")  # how a rotor's drive is given: a formula string, or a controller table
Drive = Annotated[Union[Annotated[str, Tag("formula")], Annotated[PDControl, Tag("pd_control")]],
                  Discriminator(lambda v: "formula" if isinstance(v, str) else "pd_control" if isinstance(v, (dict, PDControl)) else None,
                                custom_error_type="drive", custom_error_message='must be a formula "..." or { type = "pd_control", … }')]


class Rotor(_Model):
    """A rotor (a wheel) spinning relative to the body about an axis fixed in it: the body becomes
    a gyrostat with the rotors' momentum h = Σ J Ω â (body frame), and
    I ω̇ + ω × (I ω + h) = M − ḣ (Zhukovsky–Volterra for constant spins).  ``[body]``'s inertia is
    the whole gyrostat's, each rotor counted as if locked to the body.  Give ``inertia`` (J, about
    the axis) and ``spin`` (Ω, rad/s; or ``spin_rpm``), or ``momentum`` (J Ω, N·m·s) alone: the
    spin, constant, or the initial one of a rotor driven by ``torque`` (d(J Ω)/dt = u)."""

    @model_validator(mode="before")
    @classmethod
    def _units(cls, data: object) -> object:
        if isinstance(data, dict) and "spin_rpm" in data:
            data = dict(data)
            if "spin" in data:
                raise _invalid("spin_rpm", "give spin or spin_rpm, not both")
            try:
                data["spin"] = float(_real(data.pop("spin_rpm"))) * RPM
            except PydanticCustomError as exc:
                raise _invalid("spin_rpm", exc.message()) from None
        return data

    name: Annotated[str, Field(max_length=EVENT_NAME_LENGTH)] = ""  # how reports and the recording name it (default: its place, 1, 2, …)
    axis: Vec3  # body frame, any length (the direction is used)
    inertia: PositiveReal | None = None  # J, kg·m², about the axis
    spin_rpm: Real | None = None  # rev/min relative to the body: stored converted, as ``spin``
    spin: Real | None = None  # Ω, rad/s relative to the body, right-handed about ``axis``
    momentum: Real | None = None  # J Ω, N·m·s, instead of spin (inertia then optional: a driven rotor's speed needs it)
    # a driven rotor: its drive's torque u (N·m), J Ω̇ = u, the body feels −u â: a formula, or a controller,
    # { type = "pd_control", target…, kp, kd, max_torque }, whose body torque M the rotor supplies its share of (u = −â·M)
    torque: Drive | None = None
    constants: dict[str, Real] = {}  # names the ``torque`` formula may use
    up: Vec3 = (0.0, 0.0, 1.0)  # space frame: the direction ``gamma`` shows in the formula, in body components
    position: Vec3 | None = None  # m, body frame, where the recording draws it (no effect on the motion)

    @model_validator(mode="after")
    def _complete(self) -> Rotor:
        if not max(abs(a) for a in self.axis) >= MIN_POSITIVE:
            raise _invalid("axis", "must not be zero: give the rotor's spin axis in the body frame, e.g. [0, 0, 1]")
        if self.momentum is not None and self.spin is not None:
            raise _invalid("spin", "give momentum (J Ω) or spin (Ω, with inertia), not both")
        if self.momentum is None and (self.inertia is None or self.spin is None):
            missing = "inertia" if self.inertia is None else "spin"
            raise _invalid(missing, "a rotor needs inertia (kg·m², about its axis) and spin (rad/s, or spin_rpm), or momentum (N·m·s)")
        if isinstance(self.torque, str):
            _check_formula_inputs(self.up, self.constants)
            self.program()
        elif self.constants:
            raise _invalid("constants", "constants are for a driven rotor's torque formula: give torque = \"...\" or remove them")
        return self

    def unit_axis(self) -> np.ndarray:
        """â, body frame (scaled first: an axis of tiny components normalises without underflow)."""
        axis = np.asarray(self.axis, dtype=float)
        axis = axis / np.max(np.abs(axis))
        return axis / np.linalg.norm(axis)

    def unit_up(self) -> np.ndarray:
        """``up`` as a unit vector (space frame): what ``gamma`` shows in the drive's formula."""
        up = np.asarray(self.up, dtype=float)
        return up / np.linalg.norm(up)

    def momentum_value(self) -> float:
        """J Ω, N·m·s (at t0 for a driven rotor)."""
        return float(self.momentum) if self.momentum is not None else float(self.inertia) * float(self.spin)  # type: ignore[arg-type]

    def program(self) -> tuple[expressions.Program, int]:
        """The drive's torque formula as (program, stack depth)."""
        try:
            return expressions.parse_formula(self.torque, self.constants)  # type: ignore[arg-type]
        except expressions.FormulaError as exc:
            raise _invalid("torque", str(exc)) from None

    def momentum_vector(self) -> np.ndarray:
        """h of this rotor, body frame (N·m·s): J Ω â."""
        return self.momentum_value() * self.unit_axis()


class Time(_Model):
    """Time span and output sampling.  Samples include both ends."""

    start: TimeReal = 0.0  # s
    end: TimeReal  # s
    sample_rate: PositiveReal | None = None  # samples per second (default 100)
    samples: Annotated[int, Field(ge=2, strict=True)] | None = None  # number of samples, both ends included

    @model_validator(mode="after")
    def _span(self) -> Time:
        if not self.end > self.start:
            raise _invalid("end", f"end ({self.end:g} s) must be after start ({self.start:g} s)")
        if self.sample_rate is not None and self.samples is not None:
            raise _invalid("samples", "give sample_rate or samples, not both")
        if self.sample_count < 2:
            rate = 100.0 if self.sample_rate is None else self.sample_rate
            raise _invalid(
                "end",
                f"the span ({self.end - self.start:.3g} s) is shorter than one sample interval ({1.0 / rate:.3g} s at "
                f"sample_rate {rate:g}): lengthen the span, raise sample_rate or give samples = N",
            )
        if (self.end - self.start) / (self.sample_count - 1) < TIME_RESOLUTION:
            raise _invalid(
                "sample_rate" if self.samples is None else "samples",
                "samples closer than the recording's 1 ns time resolution: lower the rate or lengthen the span",
            )
        if self.sample_count > MAX_SAMPLES:
            raise _invalid(
                "sample_rate" if self.samples is None else "samples",
                f"{self.sample_count:,} samples is beyond the limit of {MAX_SAMPLES:,}: lower the rate or shorten the span",
            )
        return self

    @property
    def sample_count(self) -> int:
        if self.samples is not None:
            return self.samples
        rate = 100.0 if self.sample_rate is None else self.sample_rate
        span = (self.end - self.start) * rate  # inf for spans near the float range: beyond the limit
        return int(min(span + 1e-9, 10 * MAX_SAMPLES)) + 1

    def sample_times(self) -> np.ndarray:
        return np.linspace(self.start, self.end, self.sample_count)


class Solver(_Model):
    """Integration method and its accuracy settings."""

    method: str = "auto"
    step: PositiveReal | None = None  # s, fixed-step methods (default from the scene's time scale)
    rtol: Annotated[float, BeforeValidator(_real), AfterValidator(_rtol), _SchemaBounds(minimum=MIN_RTOL, maximum=1.0)] = 1e-10  # adaptive methods; and fixed-step ones without a step
    atol: PositiveReal = 1e-12
    max_steps: Annotated[int, Field(gt=0, le=2**62, strict=True)] = 200_000_000
    order: Annotated[int, Field(ge=1, le=40, strict=True)] | None = None  # methods offering several orders

    @field_validator("method")
    @classmethod
    def _known(cls, name: str) -> str:
        if name not in METHOD_NAMES:
            raise PydanticCustomError(
                "rotlab", "unknown method '{name}': choose one of {choices}", {"name": name, "choices": ", ".join(METHOD_NAMES)}
            )
        return name


class Output(_Model):
    """What to record and where (path relative to the working directory)."""

    path: str | None = None  # default: <config name>.rrd
    euler_angles: bool = False
    # derived and visual series (pose, arrows, axis tip, energy, log drifts, |Λ| − 1, Euler angles, L in
    # space) keep at most this many samples (every k-th); the state and the invariants' drifts keep every sample
    visual_samples: Annotated[int, Field(ge=2, strict=True)] = 100_000
    max_megabytes: PositiveReal = 2000.0  # `rotlab run` estimates the recording's size first and refuses beyond this


INVARIANT_NAMES = invariants.NAMES


class FlipPeriod(_Model):
    """Expected period (s) of the sign reversals of one body component of ω (a full period is
    two reversals), e.g. the intermediate-axis flip."""

    expected: PositiveReal  # s
    rtol: PositiveReal = 0.01  # allowed relative deviation
    axis: Literal["x", "y", "z"] = "y"  # body axis whose ω component flips


class Checks(_Model):
    """Accuracy checks evaluated by ``rotlab batch`` (and reported by ``rotlab run``)."""

    max_drift: dict[str, PositiveReal] = {}  # invariant name → bound on max |relative drift|
    flip_period: FlipPeriod | None = None

    @field_validator("max_drift")
    @classmethod
    def _known_invariants(cls, bounds: dict[str, float]) -> dict[str, float]:
        for name in bounds:
            if name not in INVARIANT_NAMES:
                raise PydanticCustomError(
                    "rotlab", "unknown invariant '{name}': choose from {choices}", {"name": name, "choices": ", ".join(INVARIANT_NAMES)}
                )
        return bounds


def _ordered(key: str, low: float, high: float) -> None:
    if not low < high:
        raise _invalid(key, f"needs low < high, found [{low:g}, {high:g}]: write the range as [low, high]")


class Uniform(_Model):
    uniform: tuple[Real, Real]  # draw uniformly in [low, high]

    @model_validator(mode="after")
    def _range(self) -> Uniform:
        _ordered("uniform", *self.uniform)
        return self


class LogUniform(_Model):
    log_uniform: tuple[PositiveReal, PositiveReal]  # draw log-uniformly in [low, high]

    @model_validator(mode="after")
    def _range(self) -> LogUniform:
        _ordered("log_uniform", *self.log_uniform)
        return self


class Normal(_Model):
    normal: tuple[Real, PositiveReal]  # (mean, standard deviation)


class Sphere(_Model):
    sphere: PositiveReal  # a 3-vector of this length in a uniformly random direction


Distribution = Union[Uniform, LogUniform, Normal, Sphere]


def _grid_number(value: object) -> object:
    """A grid's number as ``Real`` checks it, an integer kept an integer (a case's integer key,
    such as solver.order, takes no float).  A value that is neither a number nor a list is
    refused as either (which one its key takes is checked with the scenario: ``sweep.cases``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PydanticCustomError("grid_value", "must be a number, or a list of numbers for a vector key, found {found}",
                                  {"found": repr(value)[:40]})
    number = _real(value)
    return value if isinstance(value, int) else number


# A grid value is a number or, for a vector field, a list of numbers: one variant validated, chosen
# by the value's shape, so that a bad value gets that variant's message (not every variant's).
GridNumber = Annotated[Union[int, float], BeforeValidator(_grid_number), _SchemaBounds(minimum=-MAX_MAGNITUDE, maximum=MAX_MAGNITUDE)]
GridValue = Annotated[Union[Annotated[GridNumber, Tag("number")], Annotated[list[Real], Tag("vector")]],
                      Discriminator(lambda v: "vector" if isinstance(v, (list, tuple)) else "number")]
GridValues = list[GridValue]
_DISTRIBUTIONS = {"uniform": Uniform, "log_uniform": LogUniform, "normal": Normal, "sphere": Sphere}


def _sweep_parameter(value: object) -> object:
    """A list of grid values, or a one-key table naming a distribution."""
    if isinstance(value, list):
        return value
    if isinstance(value, dict) and len(value) == 1 and next(iter(value)) in _DISTRIBUTIONS:
        return _DISTRIBUTIONS[next(iter(value))].model_validate(value)
    raise PydanticCustomError(
        "rotlab",
        "must be a list of grid values or one of { uniform = [lo, hi] }, { log_uniform = [lo, hi] }, "
        "{ normal = [mean, sd] }, { sphere = magnitude } (found {found})",
        {"found": repr(value)[:40]},
    )


SweepParameter = Annotated[
    Union[Annotated[Distribution, Tag("distribution")], Annotated[GridValues, Tag("grid")]],
    Discriminator(lambda v: "grid" if isinstance(v, list) else "distribution"),
    BeforeValidator(_sweep_parameter),
]
SWEEP_TAGS = ("distribution", "grid", "number", "vector")  # the tags above, dropped from an error's key


class Sweep(_Model):
    """Vary config fields: grid values (every combination) and random draws (``samples`` per
    grid point, reproducible from ``seed`` and the case number).  Keys are dotted paths such as
    "initial.omega", "initial.omega[2]", "body.principal_moments[0]", "loads[0].value"."""

    parameters: dict[str, SweepParameter]
    samples: Annotated[int, Field(ge=1, le=1_000_000, strict=True)] | None = None
    seed: Annotated[int, Field(ge=0, strict=True)] = 0
    device: Literal["cpu", "cuda"] = "cpu"  # "cuda": the ensemble kernels on an NVIDIA GPU (``rotlab sweep --device``)

    @model_validator(mode="after")
    def _consistent(self) -> Sweep:
        if not self.parameters:
            raise _invalid("parameters", "give at least one parameter to vary")
        random = [k for k, v in self.parameters.items() if not isinstance(v, list)]
        for key, values in self.parameters.items():
            if isinstance(values, list) and not values:
                raise _invalid(("parameters", key), "a grid needs at least one value")
        if random and self.samples is None:
            raise _invalid("samples", f"random parameters ({', '.join(random)}) need samples = N draws")
        if not random and self.samples is not None:
            raise _invalid("samples", "samples applies to random parameters only: give a distribution or remove samples")
        return self


def _table(model: type[_Model]) -> Any:
    """A table that defaults to ``model()``: built anew for each scenario (pydantic deep-copies a
    default instance, which costs twice building one), its default shown in the JSON Schema."""
    return Field(default_factory=model, json_schema_extra={"default": model().model_dump(mode="json")})


class Scenario(_Model):
    title: str = ""
    description: str = ""
    body: Body
    initial: Initial = _table(Initial)
    loads: list[Load] = []
    time: Time
    solver: Solver = _table(Solver)
    output: Output = _table(Output)
    checks: Checks = _table(Checks)
    events: list[Event] = []
    rotors: list[Rotor] = []  # a gyrostat's wheels, at constant spin or driven (``Rotor``)
    sweep: Sweep | None = None  # used by `rotlab sweep`; `rotlab run` runs the base scenario

    @model_validator(mode="after")
    def _event_names_unique(self) -> Scenario:
        seen: set[str] = set()
        for k, event in enumerate(self.events):
            if event.name in seen:
                raise PydanticCustomError("rotlab", "event name '{name}' is used twice: give each event its own name",
                                          {"key": f"events.{k}.name", "name": event.name})
            seen.add(event.name)
        return self

    def with_initial(self, initial: Initial) -> Scenario:
        """This scenario started from ``initial`` (validated), without its ``[sweep]``: what
        validating its document with that ``[initial]`` table gives, since no check of the
        scenario as a whole reads the initial conditions (a sweep's case, ``rotlab.sweep.cases``)."""
        copied = BaseModel.model_copy(self, update={"initial": initial, "sweep": None})  # (pydantic's: validates nothing)
        copied.__pydantic_fields_set__.discard("sweep")  # (a copy of this scenario's set)
        return copied

    def rotor_momentum(self, driven: bool | None = False) -> np.ndarray:
        """h = Σ J Ω â of the rotors at constant spin (``driven``: of the driven ones, at t0; None:
        of all, at t0), body frame (N·m·s; zero without)."""
        chosen = [r.momentum_vector() for r in self.rotors if driven is None or (r.torque is not None) == driven]
        return np.sum(chosen, axis=0) if chosen else np.zeros(3)

    def rotor_names(self) -> list[str]:
        """Each rotor's name: its own, else its place in ``[[rotors]]`` (1, 2, …)."""
        return [rotor.name or str(k + 1) for k, rotor in enumerate(self.rotors)]

    def driven_rotors(self) -> list[tuple[str, Rotor]]:
        """(name, rotor) of each driven rotor, in order: the state's columns after W are theirs."""
        return [(name, rotor) for name, rotor in zip(self.rotor_names(), self.rotors) if rotor.torque is not None]

    def rotor_lines(self) -> list[str]:
        """The rotors, one Markdown list line each (body frame), and their momentum h (none without rotors)."""
        lines = []
        for name, rotor in zip(self.rotor_names(), self.rotors):
            given = (f"J = {rotor.inertia:.6g} kg·m², Ω = {rotor.spin:.6g} rad/s ({rotor.spin / RPM:.6g} rpm)"
                     if rotor.momentum is None else f"J Ω = {rotor.momentum:.6g} N·m·s" + (f", J = {rotor.inertia:.6g} kg·m²" if rotor.inertia else ""))
            drive = "" if rotor.torque is None else (f"; driven: u = {rotor.torque} N·m" if isinstance(rotor.torque, str) else
                                                     f"; driven by pd_control toward {list(rotor.torque.target)}")
            lines.append(f"- rotor {name}: axis {list(rotor.axis)} (body frame), {given}{drive}")
        if self.rotors:
            lines.append(f"- rotors' momentum h: {np.array2string(self.rotor_momentum(driven=None), precision=6)} N·m·s at t0, body frame "
                         "(L = I ω + h)")
        return lines

    @model_validator(mode="after")
    def _rotors_fit_the_body(self) -> Scenario:
        """Each rotor's name its own (its place in the list when it has none); the body's inertia
        without the rotors' own, I − Σ J â âᵀ, positive definite (the body holds them)."""
        seen: set[str] = set()
        for k, name in enumerate(self.rotor_names()):
            if name in seen:
                raise PydanticCustomError("rotlab", "rotor name '{name}' is used twice: give each rotor its own name",
                                          {"key": f"rotors.{k}.name", "name": name})
            seen.add(name)
        if self.rotors:
            bare = self.body.tensor() - sum(((r.inertia or 0.0) * np.outer(r.unit_axis(), r.unit_axis()) for r in self.rotors), np.zeros((3, 3)))
            if np.min(np.linalg.eigvalsh(0.5 * (bare + bare.T))) <= 0.0:
                k = max(range(len(self.rotors)), key=lambda j: self.rotors[j].inertia or 0.0)
                raise PydanticCustomError("rotlab", "the rotors' own inertia J exceeds what the body holds about their axes: [body] gives the "
                                                    "whole gyrostat's inertia, the rotors included (as if locked), so each J must be smaller",
                                          {"key": f"rotors.{k}.inertia"})
        return self

    @model_validator(mode="after")
    def _loads_need_body_data(self) -> Scenario:
        for k, load in enumerate(self.loads):
            if isinstance(load, Gravity) and self.body.total_mass() is None:
                raise PydanticCustomError(
                    "rotlab", "gravity (loads[{k}]) needs the body's mass: add mass = ... (kg) under [body]", {"key": "body.mass", "k": k}
                )
        return self
