"""Errors raised by instrument drivers when the hardware (or its simulator) misbehaves.

These are not user mistakes (those are :class:`ornitail.core.errors.UserInputError`): they report
that an instrument stopped answering, was unplugged, or answered something the protocol does not
allow. Every message names the instrument so that a sweep aborted by one of them says which cable to
check.
"""

from __future__ import annotations


class InstrumentError(Exception):
    """Base class: something went wrong talking to the instrument ``instrument_name``."""

    def __init__(self, instrument_name: str, problem: str) -> None:
        super().__init__(f"{instrument_name}: {problem}")
        self.instrument_name = instrument_name
        self.problem = problem


class InstrumentDisconnected(InstrumentError):
    """The instrument's port or bus failed (unplugged cable, device gone, bus error, no answer)."""


class InstrumentReplyError(InstrumentError):
    """The instrument answered ``ERR ...`` or a reply the protocol does not allow."""


class InstrumentInUse(InstrumentError):
    """Another process (or another connection in this one) holds the instrument's port or bus."""
