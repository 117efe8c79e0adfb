"""Simulated instruments: ornitail's simulators of the rig's devices, the simulated rig, its server and pytest plugin.

They are backends supplied to acquisition from outside it (entry points ``rig.simulated`` and
``rig.simulator_server`` in the group ``ornitail.instruments``); acquisition does not import this package.
"""
