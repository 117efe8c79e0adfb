"""Simulated fan controller, strut pitch actuator and flapping motor, driving the tunnel simulator.

Each runs behind its own pty (see :mod:`line_instrument`) and, as its state changes, sets
the shared tunnel signal source's operating point: fan rpm -> tunnel velocity through the tunnel
table; strut angle -> pitch; motor rpm -> flapping frequency = rpm / 60 / gear ratio.
"""

from __future__ import annotations

import math

from ornitail.acquisition.fan_speed_map import FanSpeedMap
from ornitail.calibration.tunnel_table import TunnelVelocityTable
from ornitail.simulated_instruments.clock import SimulatedClock
from ornitail.simulated_instruments.line_instrument import SimulatedLineInstrument, first_order_step
from ornitail.simulated_instruments.shared_signal_source import SharedTunnelSignals
from ornitail.vehicle.constants import DELFLY_GEAR_RATIO


def _parse_number(words: list[str]) -> float | None:
    if len(words) != 2:
        return None
    try:
        value = float(words[1])
    except ValueError:
        return None
    return value if math.isfinite(value) else None


class SimulatedTunnelFan(SimulatedLineInstrument):
    """Fan controller: first-order lag (``time_constant_s``) with an acceleration limit (rpm/s)."""

    model = "ORNI-FAN"

    def __init__(
        self,
        clock: SimulatedClock,
        signals: SharedTunnelSignals,
        tunnel_table: TunnelVelocityTable,
        *,
        device_max_rpm: float | None = None,
        time_constant_s: float = 1.5,
        rate_limit_rpm_per_s: float = 400.0,
        **kwargs,
    ) -> None:
        super().__init__(clock, **kwargs)
        self.signals = signals
        self.tunnel_table = tunnel_table
        self._speed_map = FanSpeedMap(tunnel_table)
        self.device_max_rpm = float(
            device_max_rpm if device_max_rpm is not None else tunnel_table.fan_rpm[-1]
        )
        self.time_constant_s = time_constant_s
        self.rate_limit_rpm_per_s = rate_limit_rpm_per_s
        self.target_rpm = 0.0
        self.rpm = 0.0
        self._publish()

    def _publish(self) -> None:
        self.signals.set_operating_point(
            tunnel_velocity_m_s=self._speed_map.velocity_for_rpm(self.rpm)
        )

    def advance(self, dt_s: float) -> None:
        previous = self.rpm
        self.rpm = first_order_step(
            self.rpm, self.target_rpm, dt_s, self.time_constant_s, self.rate_limit_rpm_per_s
        )
        if self.rpm != previous:
            self._publish()

    def handle(self, command: str) -> str:
        words = command.split()
        keyword = words[0].upper()
        if keyword == "RPM?":
            return f"RPM {self.rpm:.1f}"
        if keyword == "TARGET?":
            return f"TARGET {self.target_rpm:.1f}"
        if keyword == "STOP":
            self.target_rpm = 0.0
            return "OK"
        if keyword == "RPM":
            value = _parse_number(words)
            if value is None:
                return "ERR RPM needs one number"
            if not 0.0 <= value <= self.device_max_rpm:
                return f"ERR rpm {value:g} outside 0..{self.device_max_rpm:g}"
            self.target_rpm = value
            return "OK"
        return f"ERR unknown command {command!r}"


class SimulatedStrutActuator(SimulatedLineInstrument):
    """Pitch actuator: slews at ``slew_rate_deg_s`` to the target, must be homed first."""

    model = "ORNI-STRUT"

    def __init__(
        self,
        clock: SimulatedClock,
        signals: SharedTunnelSignals,
        *,
        slew_rate_deg_s: float = 10.0,
        travel_min_deg: float = -30.0,
        travel_max_deg: float = 60.0,
        power_on_angle_deg: float = 3.7,
        **kwargs,
    ) -> None:
        super().__init__(clock, **kwargs)
        self.signals = signals
        self.slew_rate_deg_s = slew_rate_deg_s
        self.travel_min_deg = travel_min_deg
        self.travel_max_deg = travel_max_deg
        self.angle_deg = power_on_angle_deg
        self.target_deg = power_on_angle_deg
        self.homed = False
        self.homing = False
        self._publish()

    def _publish(self) -> None:
        self.signals.set_operating_point(pitch_rad=math.radians(self.angle_deg))

    def advance(self, dt_s: float) -> None:
        previous = self.angle_deg
        self.angle_deg = first_order_step(
            self.angle_deg, self.target_deg, dt_s, 0.0, self.slew_rate_deg_s
        )
        if self.homing and self.angle_deg == self.target_deg:
            self.homing = False
            self.homed = True
        if self.angle_deg != previous:
            self._publish()

    def handle(self, command: str) -> str:
        words = command.split()
        keyword = words[0].upper()
        if keyword == "ANGLE?":
            return f"ANGLE {self.angle_deg:.4f}"
        if keyword == "STATUS?":
            moving = int(self.angle_deg != self.target_deg)
            return f"STATUS homed={int(self.homed)} moving={moving}"
        if keyword == "LIMITS?":
            return f"LIMITS {self.travel_min_deg:.3f} {self.travel_max_deg:.3f}"
        if keyword == "HOME":
            self.homing = True
            self.homed = False
            self.target_deg = 0.0
            return "OK"
        if keyword == "HALT":
            self.target_deg = self.angle_deg
            self.homing = False
            return "OK"
        if keyword == "ANGLE":
            value = _parse_number(words)
            if value is None:
                return "ERR ANGLE needs one number"
            if not self.homed:
                return "ERR not homed"
            if not self.travel_min_deg <= value <= self.travel_max_deg:
                travel = f"{self.travel_min_deg:g}..{self.travel_max_deg:g}"
                return f"ERR angle {value:g} outside travel {travel} deg"
            self.target_deg = value
            return "OK"
        return f"ERR unknown command {command!r}"


class SimulatedFlappingMotor(SimulatedLineInstrument):
    """Motor controller: rpm follows the target with a first-order lag (``time_constant_s``)."""

    model = "ORNI-MOTOR"

    def __init__(
        self,
        clock: SimulatedClock,
        signals: SharedTunnelSignals,
        *,
        full_throttle_rpm: float = 30_000.0,
        time_constant_s: float = 0.2,
        gear_ratio: float = DELFLY_GEAR_RATIO,
        **kwargs,
    ) -> None:
        super().__init__(clock, **kwargs)
        self.signals = signals
        self.full_throttle_rpm = full_throttle_rpm
        self.time_constant_s = time_constant_s
        self.gear_ratio = gear_ratio
        self.target_rpm = 0.0
        self.rpm = 0.0
        self._publish()

    def _publish(self) -> None:
        self.signals.set_operating_point(flapping_frequency_hz=self.rpm / 60.0 / self.gear_ratio)

    def advance(self, dt_s: float) -> None:
        previous = self.rpm
        self.rpm = first_order_step(self.rpm, self.target_rpm, dt_s, self.time_constant_s, math.inf)
        if abs(self.rpm - self.target_rpm) < 0.05:
            self.rpm = self.target_rpm
        if self.rpm != previous:
            self._publish()

    def handle(self, command: str) -> str:
        words = command.split()
        keyword = words[0].upper()
        if keyword == "RPM?":
            return f"RPM {self.rpm:.1f}"
        if keyword == "OFF":
            self.target_rpm = 0.0
            return "OK"
        if keyword in ("RPM", "THROTTLE"):
            value = _parse_number(words)
            if value is None:
                return f"ERR {keyword} needs one number"
            if keyword == "THROTTLE":
                if not 0.0 <= value <= 1.0:
                    return f"ERR throttle {value:g} outside 0..1"
                value *= self.full_throttle_rpm
            elif not 0.0 <= value <= self.full_throttle_rpm:
                return f"ERR rpm {value:g} outside 0..{self.full_throttle_rpm:g}"
            self.target_rpm = value
            return "OK"
        return f"ERR unknown command {command!r}"
