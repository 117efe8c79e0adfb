"""The tunnel rig's analog signals, in the order the acquisition board samples them (volts).

Six strain-gauge bridges of the Nano-17 balance, the hot-wire bridge, the thermocouple amplifier and the Hall
sensor of the flapping mechanism. The simulator produces these signals and the acquisition board's protocol
carries them in this order (docs/daq-protocol.md).
"""

TUNNEL_SIGNAL_CHANNELS: tuple[str, ...] = (
    "gauge_0_v",
    "gauge_1_v",
    "gauge_2_v",
    "gauge_3_v",
    "gauge_4_v",
    "gauge_5_v",
    "hotwire_bridge_v",
    "thermocouple_v",
    "hall_v",
)
GAUGE_CHANNELS: tuple[str, ...] = TUNNEL_SIGNAL_CHANNELS[:6]
"""The six strain-gauge bridges alone (what a gauge-only balance such as the NETCANOEM or the Net F/T carries)."""
