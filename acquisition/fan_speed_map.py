"""Tunnel velocity <-> fan speed <-> drive output frequency: the one home of that conversion.

The tunnel table (``[tunnel].table``) maps fan speed (rev/min) to jet velocity (m/s). A fan driven by a
variable-frequency drive is commanded in hertz of drive output; ``fan_rpm_per_hz`` (from the rig file) relates the
two (a 4-pole induction motor driving the fan directly turns at most 120 / 4 = 30 rev/min per Hz, a little less
under load). Measured speeds outside the table are clamped to its ends when read back (a fan at rest reads the
table's first velocity), set points outside it are refused by the table.
"""

from __future__ import annotations

from dataclasses import dataclass

from ornitail.calibration.tunnel_table import TunnelVelocityTable


@dataclass(frozen=True)
class FanSpeedMap:
    """Converts between tunnel velocity (m/s), fan speed (rev/min) and drive frequency (Hz).

    Attributes
    ----------
    table : TunnelVelocityTable
        Fan rpm to velocity.
    fan_rpm_per_hz : float | None
        Fan speed per hertz of drive output frequency, rev/min/Hz (None: the fan is not driven by frequency).
    """

    table: TunnelVelocityTable
    fan_rpm_per_hz: float | None = None

    @property
    def max_table_rpm(self) -> float:
        """Highest fan speed of the table, rev/min."""
        return float(self.table.fan_rpm[-1])

    def rpm_for_velocity(self, velocity_m_s: float) -> float:
        """Fan speed (rev/min) for jet velocity ``velocity_m_s`` (m/s); outside the table is refused."""
        return float(self.table.rpm_for_velocity(velocity_m_s))

    def velocity_for_rpm(self, fan_rpm: float) -> float:
        """Jet velocity (m/s) at measured fan speed ``fan_rpm`` (rev/min), clamped to the table's range."""
        low, high = float(self.table.fan_rpm[0]), float(self.table.fan_rpm[-1])
        return float(self.table.velocity_m_s_at_rpm(min(max(float(fan_rpm), low), high)))

    def _rpm_per_hz(self) -> float:
        if self.fan_rpm_per_hz is None:
            raise RuntimeError(
                "this fan speed map has no fan_rpm_per_hz (not a frequency-driven fan)"
            )
        return self.fan_rpm_per_hz

    def frequency_hz_for_rpm(self, fan_rpm: float) -> float:
        """Drive output frequency (Hz) for fan speed ``fan_rpm`` (rev/min)."""
        return float(fan_rpm) / self._rpm_per_hz()

    def rpm_for_frequency_hz(self, frequency_hz: float) -> float:
        """Fan speed (rev/min) at drive output frequency ``frequency_hz`` (Hz)."""
        return float(frequency_hz) * self._rpm_per_hz()

    def frequency_hz_for_velocity(self, velocity_m_s: float) -> float:
        """Drive output frequency (Hz) for jet velocity ``velocity_m_s`` (m/s)."""
        return self.frequency_hz_for_rpm(self.rpm_for_velocity(velocity_m_s))

    def velocity_for_frequency_hz(self, frequency_hz: float) -> float:
        """Jet velocity (m/s) at drive output frequency ``frequency_hz`` (Hz), clamped to the table."""
        return self.velocity_for_rpm(self.rpm_for_frequency_hz(frequency_hz))
