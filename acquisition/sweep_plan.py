"""Sweep plans: an explicit, checkable list of set points made from a TOML plan file.

A plan names the configuration, the steady state (theta0, V0, f0), the one-variable sweeps about it, repeats, which
points are also measured without the tail, wind-off tares, settle criteria and record length. :func:`load_plan`
gives the list of :class:`SetPoint` a sweep will visit, in order, so the whole plan can be checked against
the rig's limits, its duration estimated and a crashed run resumed at the first unfinished point before anything
moves. The file format is in ``docs/sweep-plan.md``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from ornitail.core.errors import UserInputError
from ornitail.core.input_files import read_toml_file
from ornitail.core.toml_table import TomlTable, is_finite_number

SweepVariable = Literal["theta", "velocity", "frequency"]
TaillessPoints = Literal["none", "steady_state", "all"]

# Bounds a plan must keep (docs/sweep-plan.md, "Bounds"); checked before any set point is expanded,
# so a typo cannot make a plan that never ends or exhausts memory.
MAX_RECORD_S = 600.0
"""Longest record per set point, s."""
MAX_STABLE_FOR_S = 600.0
"""Longest settle window, s."""
MAX_TIMEOUT_S = 3600.0
"""Longest settle timeout, s."""
MAX_REPEATS = 1000
"""Most repeats of a set point (steady state or sweep point)."""
MAX_SWEEP_STEPS = 1000
"""Most offsets on one side of a ``{span, steps}`` sweep, and most listed offsets / 2."""
MAX_TAIL_CHANGE_S = 3600.0
"""Longest time a tail change may be planned to take, s."""
MAX_SET_POINTS = 10_000
"""Most set points (tares included) in a plan."""
MAX_DURATION_S = 24 * 3600.0
"""Longest estimated sweep, s: set points x (record_s + stable_for_s), a lower bound."""
MAX_ABS_THETA_DEG = 90.0
"""Largest |pitch| of a steady state, deg."""
MAX_VELOCITY_M_S = 100.0
"""Largest free-stream velocity of a steady state, m/s."""
MAX_FREQUENCY_HZ = 1000.0
"""Largest flapping frequency of a steady state, Hz."""
MAX_X_H_MM = 1000.0
"""Largest tail position x_h, mm."""
MIN_SAMPLE_RATE_HZ = 100.0
"""Slowest balance sampling rate any board runs at, Hz."""
MAX_SAMPLE_RATE_HZ = 100_000.0
"""Fastest balance sampling rate accepted in a plan, Hz (the rig's board may allow less)."""

RETURN_TO_REFERENCE_SWEEP = "reference"
"""``SetPoint.sweep`` of a return to the steady state after a sweep (``[protocol] return_to_reference``)."""


@dataclass(frozen=True)
class SetPoint:
    """One point of a sweep: where to go and what to record there.

    Attributes
    ----------
    index : int
        Position in the plan, from 0.
    kind : {"tare", "measurement"}
        A wind-off tare (fan and motor off) or a measurement.
    sweep : str
        ``"tare"``, ``"steady_state"``, ``"theta"``, ``"velocity"``, ``"frequency"`` or ``"reference"`` (the
        steady state again at the end of a sweep, ``[protocol] return_to_reference``).
    tail_attached : bool
        Whether the tail is on the vehicle.
    pitch_rad : float
        Strut pitch angle, radians.
    tunnel_velocity_m_s : float
        Free-stream velocity, m/s (0 for a tare).
    flapping_frequency_hz : float
        Flapping frequency, Hz (0 for a tare: motor off).
    repeat : int
        Repeat number of this set point, from 0.
    record_s : float
        Record length, seconds.
    """

    index: int
    kind: Literal["tare", "measurement"]
    sweep: str
    tail_attached: bool
    pitch_rad: float
    tunnel_velocity_m_s: float
    flapping_frequency_hz: float
    repeat: int
    record_s: float

    @property
    def label(self) -> str:
        """Short human-readable description with units."""
        tail = "tailed" if self.tail_attached else "tailless"
        return (
            f"#{self.index} {self.sweep} {tail} theta={math.degrees(self.pitch_rad):.2f} deg "
            f"V={self.tunnel_velocity_m_s:.3f} m/s f={self.flapping_frequency_hz:.2f} Hz"
        )

    def as_record(self) -> dict[str, Any]:
        """Plain JSON-serialisable dictionary of the set point."""
        return asdict(self)


@dataclass(frozen=True)
class SettleCriteria:
    """When a set point counts as reached.

    Attributes
    ----------
    pitch_tolerance_rad, velocity_tolerance_m_s, frequency_tolerance_hz : float
        Largest accepted distance of each reading from its set value.
    stable_for_s : float
        All readings must stay within tolerance for this long, seconds.
    timeout_s : float
        Give up on the point (and stop the sweep) after this long, seconds.
    """

    pitch_tolerance_rad: float = math.radians(0.2)
    velocity_tolerance_m_s: float = 0.02
    frequency_tolerance_hz: float = 0.1
    stable_for_s: float = 1.0
    timeout_s: float = 60.0


@dataclass(frozen=True)
class SweepPlan:
    """A parsed plan file; ``set_points`` lists the points in the order a sweep visits them."""

    name: str
    tail_id: str
    x_h_m: float
    theta0_rad: float
    velocity0_m_s: float
    frequency0_hz: float
    sweep_offsets: dict[SweepVariable, tuple[float, ...]]
    steady_state_repeats: int
    sweep_repeats: int
    tailless_points: TaillessPoints
    wind_off_tares: bool
    record_s: float
    sample_rate_hz: float
    settle: SettleCriteria
    source: str = "<plan>"
    bracketing_tares: bool = False
    points_per_block: int = 0
    interleave_tail_states: bool = False
    return_to_reference: bool = False
    tail_change_s: float = 0.0
    set_points: tuple[SetPoint, ...] = field(default=(), compare=False)


_SWEEP_KEYS: dict[str, tuple[SweepVariable, float]] = {
    "theta_deg": ("theta", math.pi / 180.0),
    "v_m_s": ("velocity", 1.0),
    "f_hz": ("frequency", 1.0),
}


def _sweep_offsets(source: str, table: Any) -> dict[SweepVariable, tuple[float, ...]]:
    """Offsets of each one-variable sweep, SI; given as a list or as ``span`` and ``steps``."""
    if table is None:
        return {}
    reader = TomlTable(source, "sweeps", table, _SWEEP_KEYS)
    offsets: dict[SweepVariable, tuple[float, ...]] = {}
    for key, (variable, to_si) in _SWEEP_KEYS.items():
        if key not in table:
            continue
        spec = table[key]
        where = reader.where(key)
        if isinstance(spec, list):
            values = spec
        elif isinstance(spec, dict) and set(spec) == {"span", "steps"}:
            span_and_steps = TomlTable(source, f"sweeps.{key}", spec, {"span", "steps"})
            span = span_and_steps.number("span", positive=True)
            steps = span_and_steps.integer("steps", minimum=1, maximum=MAX_SWEEP_STEPS)
            values = [span * k / steps for k in range(-steps, steps + 1) if k != 0]
        else:
            raise UserInputError(
                where, "must be a list of offsets or a table {span = ..., steps = ...}"
            )
        if len(values) > 2 * MAX_SWEEP_STEPS:
            raise UserInputError(
                where, f"{len(values)} offsets; at most {2 * MAX_SWEEP_STEPS} are allowed"
            )
        for value in values:
            if not is_finite_number(value):
                raise UserInputError(where, f"offset {value!r} is not a finite number")
        if any(value == 0 for value in values):
            raise UserInputError(where, "an offset of 0 is the steady state; list it under repeats")
        offsets[variable] = tuple(float(value) * to_si for value in values)
    return offsets


def load_plan(path: str | Path) -> SweepPlan:
    """Read and check a plan file; every mistake is a :class:`UserInputError` naming the field."""
    path = Path(path)
    return plan_from_document(read_toml_file(path), str(path))


def plan_from_document(document: dict[str, Any], source: str = "<plan>") -> SweepPlan:
    """Build a :class:`SweepPlan` from a parsed TOML document (see ``docs/sweep-plan.md``)."""
    known_tables = {"plan", "configuration", "steady_state", "sweeps", "protocol", "settle"}
    unknown = sorted(set(document) - known_tables)
    if unknown:
        raise UserInputError(f"{source}: [{unknown[0]}]", "unknown table")
    plan_table = TomlTable(source, "plan", document.get("plan", {}), {"name"})
    configuration = TomlTable(
        source, "configuration", document.get("configuration"), {"tail_id", "x_h_mm"}
    )
    steady = TomlTable(
        source, "steady_state", document.get("steady_state"), {"theta_deg", "v_m_s", "f_hz"}
    )
    protocol = TomlTable(
        source,
        "protocol",
        document.get("protocol", {}),
        {
            "steady_state_repeats",
            "sweep_repeats",
            "tailless_points",
            "wind_off_tares",
            "bracketing_tares",
            "points_per_block",
            "interleave_tail_states",
            "return_to_reference",
            "tail_change_s",
            "record_s",
            "sample_rate_hz",
        },
    )
    settle_table = TomlTable(
        source,
        "settle",
        document.get("settle", {}),
        {
            "pitch_tolerance_deg",
            "velocity_tolerance_m_s",
            "frequency_tolerance_hz",
            "stable_for_s",
            "timeout_s",
        },
    )
    defaults = SettleCriteria()
    settle = SettleCriteria(
        pitch_tolerance_rad=math.radians(
            settle_table.number(
                "pitch_tolerance_deg",
                math.degrees(defaults.pitch_tolerance_rad),
                positive=True,
            )
        ),
        velocity_tolerance_m_s=settle_table.number(
            "velocity_tolerance_m_s", defaults.velocity_tolerance_m_s, positive=True
        ),
        frequency_tolerance_hz=settle_table.number(
            "frequency_tolerance_hz", defaults.frequency_tolerance_hz, positive=True
        ),
        stable_for_s=_at_most(
            settle_table,
            "stable_for_s",
            settle_table.number("stable_for_s", defaults.stable_for_s, minimum=0.0),
            MAX_STABLE_FOR_S,
        ),
        timeout_s=_at_most(
            settle_table,
            "timeout_s",
            settle_table.number("timeout_s", defaults.timeout_s, positive=True),
            MAX_TIMEOUT_S,
        ),
    )
    plan = SweepPlan(
        name=plan_table.text("name", default=Path(source).stem),
        tail_id=configuration.text("tail_id"),
        x_h_m=_within(configuration, "x_h_mm", 0.0, MAX_X_H_MM, "mm", positive=True) / 1000.0,
        theta0_rad=math.radians(
            _within(steady, "theta_deg", -MAX_ABS_THETA_DEG, MAX_ABS_THETA_DEG, "deg")
        ),
        velocity0_m_s=_within(steady, "v_m_s", 0.0, MAX_VELOCITY_M_S, "m/s"),
        frequency0_hz=_within(steady, "f_hz", 0.0, MAX_FREQUENCY_HZ, "Hz", positive=True),
        sweep_offsets=_sweep_offsets(source, document.get("sweeps")),
        steady_state_repeats=protocol.integer(
            "steady_state_repeats", 3, minimum=1, maximum=MAX_REPEATS
        ),
        sweep_repeats=protocol.integer("sweep_repeats", 1, minimum=1, maximum=MAX_REPEATS),
        tailless_points=protocol.text(  # type: ignore[arg-type]
            "tailless_points", "steady_state", choices=("none", "steady_state", "all")
        ),
        wind_off_tares=protocol.boolean("wind_off_tares", True),
        record_s=_at_most(
            protocol, "record_s", protocol.number("record_s", 2.0, positive=True), MAX_RECORD_S
        ),
        sample_rate_hz=protocol.number("sample_rate_hz", 10_000.0, positive=True),
        settle=settle,
        source=source,
        bracketing_tares=protocol.boolean("bracketing_tares", False),
        points_per_block=protocol.integer("points_per_block", 0, minimum=0, maximum=MAX_REPEATS),
        interleave_tail_states=protocol.boolean("interleave_tail_states", False),
        return_to_reference=protocol.boolean("return_to_reference", False),
        tail_change_s=_at_most(
            protocol,
            "tail_change_s",
            protocol.number("tail_change_s", 0.0, minimum=0.0),
            MAX_TAIL_CHANGE_S,
        ),
    )
    if plan.bracketing_tares and not plan.wind_off_tares:
        raise UserInputError(
            protocol.where("bracketing_tares"),
            "true needs wind_off_tares = true (the tares it adds after each block bracket the tares before it)",
        )
    if plan.points_per_block and not plan.bracketing_tares:
        raise UserInputError(
            protocol.where("points_per_block"),
            f"{plan.points_per_block} needs bracketing_tares = true (blocks are bracketed by wind-off tares)",
        )
    if not MIN_SAMPLE_RATE_HZ <= plan.sample_rate_hz <= MAX_SAMPLE_RATE_HZ:
        raise UserInputError(
            protocol.where("sample_rate_hz"),
            f"{plan.sample_rate_hz:g} Hz is outside {MIN_SAMPLE_RATE_HZ:g}..{MAX_SAMPLE_RATE_HZ:g} Hz",
        )
    minimum_record_s = 5.0 / plan.frequency0_hz
    if plan.record_s < minimum_record_s:
        raise UserInputError(
            f"{source}: [protocol].record_s",
            f"{plan.record_s} s holds fewer than 5 flapping cycles at f0 = {plan.frequency0_hz} Hz; "
            f"use at least {minimum_record_s:.2f} s",
        )
    _check_size(plan)
    return _with_set_points(plan)


def _within(
    table: TomlTable, key: str, low: float, high: float, unit: str, positive: bool = False
) -> float:
    """A finite number of ``key`` in ``low..high`` (``positive``: above 0)."""
    value = table.number(key, positive=positive)
    if not low <= value <= high:
        raise UserInputError(
            table.where(key), f"{value:g} {unit} is outside {low:g}..{high:g} {unit}"
        )
    return value


def _at_most(table: TomlTable, key: str, value: float, maximum: float) -> float:
    """``value`` of ``key``, refused above ``maximum``."""
    if value > maximum:
        raise UserInputError(
            table.where(key), f"{value:g} s is more than the {maximum:g} s allowed"
        )
    return value


@dataclass(frozen=True)
class _Segment:
    """Measurements of one tail state recorded without a tail change between them (one run of a sweep)."""

    tail_attached: bool
    steady_state_repeats: tuple[int, ...]
    with_sweeps: bool


def _segments(plan: SweepPlan) -> list[_Segment]:
    """The plan's segments in time order: each tail state once, or, with ``interleave_tail_states``, the
    steady-state repeats alternating tailed, tailless, tailed, ... with the sweeps in the first of each state."""
    states = [True] if plan.tailless_points == "none" else [True, False]
    repeats = range(plan.steady_state_repeats)

    def sweeps_for(tail_attached: bool) -> bool:
        return tail_attached or plan.tailless_points == "all"

    if not plan.interleave_tail_states or len(states) == 1:
        return [_Segment(state, tuple(repeats), sweeps_for(state)) for state in states]
    return [
        _Segment(state, (repeat,), sweeps_for(state) and repeat == 0)
        for repeat in repeats
        for state in states
    ]


def _group_sizes(plan: SweepPlan, segment: _Segment) -> list[int]:
    """How many measurements each pitch group of ``segment`` holds, in time order (see :func:`_pitch_groups`)."""
    steady = len(segment.steady_state_repeats)
    if not segment.with_sweeps:
        return [steady]
    at_steady_pitch = steady + sum(
        plan.sweep_repeats * len(plan.sweep_offsets.get(variable, ()))
        + int(plan.return_to_reference and bool(plan.sweep_offsets.get(variable)))
        for variable in ("velocity", "frequency")
    )
    pitch_offsets = {offset for offset in plan.sweep_offsets.get("theta", ()) if offset != 0}
    returning = int(plan.return_to_reference and bool(pitch_offsets))
    return [at_steady_pitch] + [plan.sweep_repeats] * len(pitch_offsets) + [1] * returning


def set_point_count(plan: SweepPlan) -> int:
    """How many set points (tares included) ``plan`` expands to, counted without expanding it."""
    return sum(
        size + _tares_at_a_pitch(plan, size)
        for segment in _segments(plan)
        for size in _group_sizes(plan, segment)
    )


def _tares_at_a_pitch(plan: SweepPlan, point_count: int) -> int:
    """Wind-off tares at one pitch: one before its points and, with bracketing, one after each block of at most
    ``points_per_block`` (all of them when 0)."""
    if not plan.wind_off_tares:
        return 0
    if not plan.bracketing_tares:
        return 1
    blocks = -(-point_count // plan.points_per_block) if plan.points_per_block else 1
    return 1 + blocks


def estimated_duration_s(plan: SweepPlan, point_count: int | None = None) -> float:
    """A lower bound of a sweep's duration, s: set points x (record_s + stable_for_s), plus ``tail_change_s``
    for every tail change between segments."""
    count = set_point_count(plan) if point_count is None else point_count
    tail_changes = len(_segments(plan)) - 1
    return count * (plan.record_s + plan.settle.stable_for_s) + tail_changes * plan.tail_change_s


def _check_size(plan: SweepPlan) -> None:
    """Refuse a plan of more than :data:`MAX_SET_POINTS` points or longer than a day."""
    count = set_point_count(plan)
    if count > MAX_SET_POINTS:
        raise UserInputError(
            plan.source,
            f"the plan has {count} set points, more than the {MAX_SET_POINTS} allowed "
            "(fewer repeats or sweep steps)",
        )
    duration_s = estimated_duration_s(plan, count)
    if duration_s > MAX_DURATION_S:
        raise UserInputError(
            plan.source,
            f"the plan takes at least {duration_s / 3600:.1f} h ({count} set points x "
            f"(record_s + stable_for_s), and tail_change_s per tail change), more than the "
            f"{MAX_DURATION_S / 3600:g} h allowed; "
            "split it into several plans",
        )


def _point(plan: SweepPlan, sweep: str, repeat: int, **offsets: float) -> dict[str, Any]:
    """A measurement at the steady state moved by ``offsets`` (SI, by set-point field)."""
    point = {
        "sweep": sweep,
        "repeat": repeat,
        "pitch_rad": plan.theta0_rad,
        "tunnel_velocity_m_s": plan.velocity0_m_s,
        "flapping_frequency_hz": plan.frequency0_hz,
    }
    for key, offset in offsets.items():
        point[key] += offset
    return point


_SWEEP_FIELDS = {
    "theta": "pitch_rad",
    "velocity": "tunnel_velocity_m_s",
    "frequency": "flapping_frequency_hz",
}


def _pitch_groups(plan: SweepPlan, segment: _Segment) -> list[list[dict[str, Any]]]:
    """The measurements of ``segment`` grouped by pitch in time order: the pitches in increasing order (the
    steady-state pitch holds the steady states, then the velocity and frequency sweeps, each followed by a
    return-to-reference point with ``return_to_reference``), then, with that option and a pitch sweep, one more
    reference point at the steady state after the pitch sweep's last pitch."""
    steady = [_point(plan, "steady_state", repeat) for repeat in segment.steady_state_repeats]
    if not segment.with_sweeps:
        return [steady]
    by_pitch: dict[float, list[dict[str, Any]]] = {plan.theta0_rad: steady}
    for variable, offsets in plan.sweep_offsets.items():
        field_name = _SWEEP_FIELDS[variable]
        for offset in sorted(offsets):
            for repeat in range(plan.sweep_repeats):
                point = _point(plan, variable, repeat, **{field_name: offset})
                by_pitch.setdefault(point["pitch_rad"], []).append(point)
        if plan.return_to_reference and offsets and variable != "theta":
            by_pitch[plan.theta0_rad].append(_point(plan, RETURN_TO_REFERENCE_SWEEP, 0))
    groups = [by_pitch[pitch] for pitch in sorted(by_pitch)]
    if plan.return_to_reference and plan.sweep_offsets.get("theta"):
        groups.append([_point(plan, RETURN_TO_REFERENCE_SWEEP, 0)])
    return groups


def _with_set_points(plan: SweepPlan) -> SweepPlan:
    """Expand the plan: segment by segment (:func:`_segments`), each pitch group (:func:`_pitch_groups`) gets its
    tare, then its points (with ``bracketing_tares``, a tare at the same pitch after each block of at most
    ``points_per_block`` of them, so the balance's drift across every block is measured)."""
    ordered: list[dict[str, Any]] = []
    for segment in _segments(plan):
        for group in _pitch_groups(plan, segment):
            tare = {
                "kind": "tare",
                "sweep": "tare",
                "repeat": 0,
                "pitch_rad": group[0]["pitch_rad"],
                "tunnel_velocity_m_s": 0.0,
                "flapping_frequency_hz": 0.0,
                "tail_attached": segment.tail_attached,
            }
            points = [
                {**point, "kind": "measurement", "tail_attached": segment.tail_attached}
                for point in group
            ]
            if plan.wind_off_tares:
                ordered.append(tare)
            size = plan.points_per_block or len(points)
            for block, start in enumerate(range(0, len(points), size), start=1):
                ordered.extend(points[start : start + size])
                if plan.bracketing_tares:
                    ordered.append({**tare, "repeat": block})
    set_points = tuple(
        SetPoint(index=index, record_s=plan.record_s, **point)
        for index, point in enumerate(ordered)
    )
    return SweepPlan(**{**plan.__dict__, "set_points": set_points})


def zero_references(set_points: Sequence[SetPoint], measurements: Iterable[int]) -> set[int]:
    """Plan indices of the wind-off tares that give the measurements ``measurements`` (plan indices) their zero:
    per measurement, the nearest tare at its pitch before it and the nearest after it, both within its stretch
    of one tail state (a tail change starts a new run, whose stream the tares of another run do not zero).

    A resumed sweep records these again with the points it records again: a point's zero must come from its
    own run, taken minutes (not an hour and a restart) from it, or the balance's drift is in its loads.
    """
    wanted = set(measurements)
    references: set[int] = set()
    for position, point in enumerate(set_points):
        if point.index not in wanted or point.kind == "tare":
            continue
        for step in (-1, 1):
            other = position + step
            while 0 <= other < len(set_points):
                candidate = set_points[other]
                if candidate.tail_attached != point.tail_attached:
                    break
                if candidate.kind == "tare" and math.isclose(
                    candidate.pitch_rad, point.pitch_rad, abs_tol=1e-9
                ):
                    references.add(candidate.index)
                    break
                other += step
    return references


def motor_rpm_violations(
    plan: SweepPlan,
    gear_ratio: float,
    max_motor_rpm: float,
    frequency_limit_hz: float = math.inf,
) -> list[str]:
    """Set points whose flapping frequency the motor cannot reach, one line each (empty: none).

    A frequency f needs motor rpm = f * 60 * ``gear_ratio``, at most ``max_motor_rpm``. Points above
    ``frequency_limit_hz`` are left out (they are reported as outside the rig's frequency limits).
    """
    violations = []
    for point in plan.set_points:
        if point.flapping_frequency_hz > frequency_limit_hz:
            continue
        rpm = point.flapping_frequency_hz * 60.0 * gear_ratio
        if rpm > max_motor_rpm:
            violations.append(
                f"set point #{point.index} ({point.sweep}): f = {point.flapping_frequency_hz:.3f} Hz "
                f"needs {rpm:.0f} motor rpm (f * 60 * gear ratio {gear_ratio:g}), more than "
                f"[limits].max_motor_rpm = {max_motor_rpm:g}"
            )
    return violations


def sample_rate_violation(plan: SweepPlan, max_sample_rate_hz: float) -> str | None:
    """Why the balance board cannot sample at the plan's rate, or None when it can."""
    if MIN_SAMPLE_RATE_HZ <= plan.sample_rate_hz <= max_sample_rate_hz:
        return None
    return (
        f"[protocol].sample_rate_hz = {plan.sample_rate_hz:g} Hz is outside what the balance "
        f"board can do ({MIN_SAMPLE_RATE_HZ:g}..{max_sample_rate_hz:g} Hz at the rig's baud rate)"
    )


def limit_violations(plan: SweepPlan, limits: dict[str, tuple[float, float]]) -> list[str]:
    """Every set point outside the rig's limits, one line each (empty when the plan fits).

    Parameters
    ----------
    plan : SweepPlan
        The expanded plan.
    limits : dict
        Closed ranges by set-point field: ``pitch_rad``, ``tunnel_velocity_m_s``, ``flapping_frequency_hz``,
        SI units. Tares (fan and motor off) are checked for pitch only.
    """
    units = {
        "pitch_rad": ("theta", "deg", math.degrees),
        "tunnel_velocity_m_s": ("V", "m/s", float),
        "flapping_frequency_hz": ("f", "Hz", float),
    }
    violations = []
    for point in plan.set_points:
        for field_name, (low, high) in limits.items():
            if point.kind == "tare" and field_name != "pitch_rad":
                continue
            value = getattr(point, field_name)
            if not low <= value <= high:
                symbol, unit, to_user = units[field_name]
                violations.append(
                    f"set point #{point.index} ({point.sweep}): {symbol} = {to_user(value):.3f} {unit} "
                    f"is outside the rig's limits [{to_user(low):.3f}, {to_user(high):.3f}] {unit}"
                )
    return violations
