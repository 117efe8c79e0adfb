"""The simulator's truth for a tunnel configuration: the quantities ``ornitail process`` estimates, exactly.

``ornitail process`` subtracts a wind-off tare at the same pitch (motor off, fan off: weight only) from each
wind-on point, so what it reports is the cycle-averaged aerodynamic load of the clamped vehicle, X, Z (N) and M
(N m, positive nose-down), in the body frame of docs/frames.md about the rig's reference point (the point the
rig file's ``[balance].tool_transform_mm_deg`` moves the sensor's origin to). Its derivatives are the slopes of
those loads with respect to the body velocities u = -V cos(theta), w = -V sin(theta) and the flapping frequency f
at the steady state.

Here they are computed from the physics: the cycle-averaged loads of ``PreparedVehicle`` in the tunnel
environment (the effects that act on the air and the vehicle: strut interference, clamping, wake profile, CG
shift, day-to-day drift), moved to the sensor origin as the simulated balance sees them, then through the same
tool transform processing uses. The sensor's own effects (noise, quantisation, thermal drift, resonance, hot-wire
temperature) are left out: they do not change the quantity being estimated. Derivatives are central differences.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ornitail.calibration.tool_transform import ToolTransform
from ornitail.core.units import quotient_unit
from ornitail.sim.configuration import VehicleConfiguration
from ornitail.sim.effects import EffectSet
from ornitail.sim.model import PreparedVehicle
from ornitail.sim.tunnel import sensor_frame_loads

LOAD_KEYS = (("X", "x_n", "N"), ("Z", "z_n", "N"), ("M", "m_n_m", "N m"))
"""Load symbol, JSON key (unit in the name) and unit, in the order of ``balance.derivatives``."""
_BODY_INDEX = {"X": 0, "Z": 2, "M": 4}
"""Where X, Z and M sit in a body-frame wrench [X, Y, Z, L, M, N]."""
VARIABLE_STEPS = (("u", "m/s", 1e-3), ("w", "m/s", 1e-3), ("f", "Hz", 1e-2))
"""Variable symbol, unit and central-difference step (m/s, m/s, Hz): small against the sweeps' +-0.2 m/s and
+-1 Hz, large against the model's round-off (loads ~1e-2 N computed to ~1e-15)."""


@dataclass(frozen=True)
class TunnelTruth:
    """True cycle-averaged aerodynamic loads and derivatives of one configuration at one tunnel point.

    Attributes
    ----------
    configuration_name : str
    tail_attached : bool
    pitch_rad, tunnel_velocity_m_s, flapping_frequency_hz : float
        The operating point (rad, m/s, Hz).
    loads : dict
        ``x_n``, ``z_n`` (N) and ``m_n_m`` (N m) about the reference point, body frame.
    derivatives : dict
        ``Xu`` ... ``Mf`` (N/(m/s), N m/(m/s), N/Hz, N m/Hz).
    reference_transform : ToolTransform
        Sensor origin and axes -> reference point and body axes (the rig file's tool transform).
    """

    configuration_name: str
    tail_attached: bool
    pitch_rad: float
    tunnel_velocity_m_s: float
    flapping_frequency_hz: float
    loads: dict[str, float]
    derivatives: dict[str, float]
    reference_transform: ToolTransform = field(default_factory=ToolTransform)

    def to_json_dict(self) -> dict[str, Any]:
        """JSON-ready: operating point in degrees at the edge, loads and derivatives with units."""
        units = {
            f"{load}{variable}": _derivative_unit(load, variable) for load, variable in _pairs()
        }
        return {
            "configuration": self.configuration_name,
            "tail_attached": self.tail_attached,
            "operating_point": {
                "theta_deg": math.degrees(self.pitch_rad),
                "v_m_s": self.tunnel_velocity_m_s,
                "f_hz": self.flapping_frequency_hz,
            },
            "frame": "study body frame (docs/frames.md): x_b aft in forward flight, z_b nose to tail, "
            "M nose-down",
            "reference_point_tool_transform_mm_deg": [
                round(value, 6) + 0.0 for value in self.reference_transform.as_mm_deg()
            ],
            "loads": dict(self.loads),
            "derivatives": {
                name: {"value": value, "unit": units[name]}
                for name, value in self.derivatives.items()
            },
            "effects": "the simulator's effects on the air and the vehicle; none of the sensor's",
        }


def _pairs() -> list[tuple[str, str]]:
    return [(load, variable) for load, _, _ in LOAD_KEYS for variable, _, _ in VARIABLE_STEPS]


def _derivative_unit(load: str, variable: str) -> str:
    load_unit = {symbol: unit for symbol, _, unit in LOAD_KEYS}[load]
    return quotient_unit(load_unit, {symbol: unit for symbol, unit, _ in VARIABLE_STEPS}[variable])


def _reference_point_loads(
    vehicle: PreparedVehicle, transform: ToolTransform, u_m_s: float, w_m_s: float, f_hz: float
) -> np.ndarray:
    """Aerodynamic [X, Y, Z, L, M, N] about the reference point in body axes (no weight: the tare removes it)."""
    loads = vehicle.loads(u_m_s, w_m_s, 0.0, f_hz, 0.0)
    sensor = sensor_frame_loads(loads.x_n, loads.z_n, loads.m_n_m, vehicle)[0]
    return transform.wrench_matrix() @ sensor


def tunnel_truth(
    configuration: VehicleConfiguration,
    pitch_rad: float,
    tunnel_velocity_m_s: float,
    flapping_frequency_hz: float,
    *,
    tail_attached: bool = True,
    effects: EffectSet | None = None,
    reference_transform: ToolTransform | None = None,
) -> TunnelTruth:
    """The loads and derivatives ``ornitail process`` estimates for this configuration and point.

    ``reference_transform`` is the rig file's tool transform (sensor origin -> reference point, sensor axes ->
    body axes); without it the sensor origin and a body-aligned frame are used.
    """
    transform = reference_transform or ToolTransform()
    built = configuration if tail_attached else configuration.without_tail()
    vehicle = PreparedVehicle(built, effects or EffectSet(), "tunnel")
    u0 = -tunnel_velocity_m_s * math.cos(pitch_rad)
    w0 = -tunnel_velocity_m_s * math.sin(pitch_rad)
    centre = {"u": u0, "w": w0, "f": flapping_frequency_hz}

    def wrench(**offsets: float) -> np.ndarray:
        point = {name: value + offsets.get(name, 0.0) for name, value in centre.items()}
        return _reference_point_loads(vehicle, transform, point["u"], point["w"], point["f"])

    at_point = wrench()
    loads = {key: float(at_point[_BODY_INDEX[load]]) for load, key, _ in LOAD_KEYS}
    slopes = {
        variable: (wrench(**{variable: step}) - wrench(**{variable: -step})) / (2.0 * step)
        for variable, _, step in VARIABLE_STEPS
    }
    derivatives = {
        f"{load}{variable}": float(slopes[variable][_BODY_INDEX[load]])
        for load, variable in _pairs()
    }
    return TunnelTruth(
        configuration_name=configuration.name,
        tail_attached=tail_attached,
        pitch_rad=float(pitch_rad),
        tunnel_velocity_m_s=float(tunnel_velocity_m_s),
        flapping_frequency_hz=float(flapping_frequency_hz),
        loads=loads,
        derivatives=derivatives,
        reference_transform=transform,
    )
