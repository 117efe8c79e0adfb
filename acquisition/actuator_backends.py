"""Actuator backends by name: the built-in ones, and third parties' through the ``ornitail.instruments`` entry points.

The rig file chooses a backend per role (``[fan] backend = "modbus_vfd"``; default ``"orni_line"``). A package
adds a backend without changing ornitail by declaring an entry point named ``<role>.<backend>`` in the group
``ornitail.instruments`` that names a class implementing the role's interface (:mod:`actuator_interfaces`)::

    [project.entry-points."ornitail.instruments"]
    "fan.nidaqmx_analog" = "my_tunnel.fan:NiDaqmxTunnelFan"

Built-in names win over entry points of the same name. Every lookup failure is a ``UserInputError`` naming the
rig file's ``[<role>].backend``. The same group supplies the rig's simulated instruments (role ``rig``,
:mod:`rig_simulation`).
"""

from __future__ import annotations

from importlib import metadata
from typing import TypeVar

from ornitail.acquisition.actuator_interfaces import ROLE_INTERFACES, Actuator, ActuatorContext
from ornitail.acquisition.modbus_vfd_driver import ModbusVfdTunnelFan
from ornitail.acquisition.orni_line_backends import (
    ORNI_LINE,
    OrniLineMotor,
    OrniLineStrut,
    OrniLineTunnelFan,
)
from ornitail.acquisition.zaber_strut_driver import ZaberAsciiStrut
from ornitail.core.errors import UserInputError

ENTRY_POINT_GROUP = "ornitail.instruments"
DEFAULT_BACKEND = ORNI_LINE
T = TypeVar("T")

BUILT_IN_BACKENDS: dict[tuple[str, str], type[Actuator]] = {
    ("fan", ORNI_LINE): OrniLineTunnelFan,
    ("fan", "modbus_vfd"): ModbusVfdTunnelFan,
    ("strut", ORNI_LINE): OrniLineStrut,
    ("strut", "zaber_ascii"): ZaberAsciiStrut,
    ("motor", ORNI_LINE): OrniLineMotor,
}
"""(role, backend name) -> backend class."""


def installed_entry_points() -> list[metadata.EntryPoint]:
    """The entry points of the group ``ornitail.instruments`` of every installed distribution."""
    return list(metadata.entry_points(group=ENTRY_POINT_GROUP))


def backend_names(role: str) -> list[str]:
    """Every backend name available for ``role``: built-in ones, then installed ones (sorted)."""
    built_in = [name for (known_role, name) in BUILT_IN_BACKENDS if known_role == role]
    prefix = f"{role}."
    installed = sorted(
        entry.name[len(prefix) :]
        for entry in installed_entry_points()
        if entry.name.startswith(prefix) and entry.name[len(prefix) :] not in built_in
    )
    return built_in + installed


def backend_class(role: str, name: str, where: str) -> type[Actuator]:
    """The backend class ``name`` of ``role``; ``where`` names the rig-file field in messages.

    Raises
    ------
    UserInputError
        No such backend, its entry point cannot be loaded, or it does not implement the role's interface.
    """
    if (role, name) in BUILT_IN_BACKENDS:
        return BUILT_IN_BACKENDS[role, name]
    return entry_point_class(
        role,
        name,
        ROLE_INTERFACES[role],
        where,
        missing=f"{name!r} is not a {role} backend; available: {', '.join(backend_names(role))}",
        registrant="third-party backends",
    )


def entry_point_class(
    role: str, name: str, interface: type[T], where: str, *, missing: str, registrant: str
) -> type[T]:
    """The class named by the entry point ``<role>.<name>`` of ``ornitail.instruments``, a subclass of
    ``interface``; ``where`` names the rig-file field in messages. With no such entry point the message is
    ``missing``, then who registers one (``registrant``) and how.

    Raises
    ------
    UserInputError
        No such entry point, it cannot be loaded, or it does not name a subclass of ``interface``.
    """
    wanted = f"{role}.{name}"
    matches = [entry for entry in installed_entry_points() if entry.name == wanted]
    if not matches:
        raise UserInputError(
            where,
            f"{missing} ({registrant} register an entry point {wanted!r} in the group {ENTRY_POINT_GROUP!r})",
        )
    entry = matches[0]
    try:
        loaded = entry.load()
    except Exception as error:  # a third party's import failing: name it, do not show its traceback
        raise UserInputError(
            where,
            f"backend {name!r} ({entry.value}) cannot be loaded: {type(error).__name__}: {error}",
        ) from None
    if not (isinstance(loaded, type) and issubclass(loaded, interface)):
        raise UserInputError(
            where,
            f"backend {name!r} ({entry.value}) is not a subclass of "
            f"{interface.__module__}.{interface.__name__}",
        )
    return loaded


def create_actuator(
    role: str, backend: type[Actuator], context: ActuatorContext, where: str
) -> Actuator:
    """Build the driver of ``role`` with ``backend.from_rig(context)``, checking it implements the role's interface.

    Raises
    ------
    UserInputError
        The backend built something that is not the role's interface (``where`` names the rig-file field).
    """
    driver = backend.from_rig(context)
    interface = ROLE_INTERFACES[role]
    if not isinstance(driver, interface):
        raise UserInputError(
            where,
            f"backend {backend.__name__} built a {type(driver).__name__}, not a {interface.__name__}",
        )
    return driver
