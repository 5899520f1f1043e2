# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
How a run stands: running, failed or stopped, why, and check's refusal of its start.

``Outcome`` is the part of ``Simulator`` that ends a run: a failure
(``fail``: a numerical one from the step loop, ``stepping.Stepper``) or a
stop that a watch asks for (``stop``: a contact pair's or an aero table's,
``watch.Watch``); a run that ended within its first step of a scenario
``cfem-sim check`` refuses takes check's line as its message
(``startcheck.start_refusal``). ``Forward`` reads such a part's attribute
through the simulator that holds it.
"""

from __future__ import annotations

from typing import Optional

from cfem_ros.core.engine.events import Failure, Status
from cfem_ros.core.engine.startcheck import start_refusal


class Forward:
    """
    An attribute of a simulator that is its part's, read and set through the part.

    ``status = Forward('outcome')`` on a class makes ``sim.status`` be
    ``sim.outcome.status``; a method of a part is forwarded as it is bound.
    """

    def __init__(self, part: str, name: Optional[str] = None):
        self.part, self.name = part, name

    def __set_name__(self, owner, name: str):
        self.name = self.name or name
        self.__doc__ = f'``{self.part}.{self.name}``'

    def __get__(self, sim, owner=None):
        return self if sim is None else getattr(getattr(sim, self.part), self.name)

    def __set__(self, sim, value):
        setattr(getattr(sim, self.part), self.name, value)


class Outcome:
    """
    How a simulator's run stands, and the one place it fails or stops.

    Parameters
    ----------
    check_start : bool
        A run that ends within its first step asks ``startcheck`` whether
        ``cfem-sim check`` refuses its scenario (False for check's own trial runs).

    Attributes
    ----------
    status : Status
        ``RUNNING``; ``FAILED`` (a non-finite state or joint load, a violation
        beyond ``DIVERGENCE_VIOLATION``, a singular solve: the last good state
        kept); ``CONTACT`` (a pair with ``on_contact: stop`` touched) or
        ``AERO_OUTSIDE`` (a table's ``outside: stop``): stopped there.
    message, reason : str
        Why it failed or stopped, with the time, and without ('' while running).
        A run that ended within its first step of a scenario ``cfem-sim
        check`` refuses has check's line as its message (``refusal``).
    refusal : str
        Check's line (``startcheck.cannot_start``) if the run ended within
        its first step and check refuses its scenario; '' otherwise.
    failure : Failure or None
        Which failure (``FAILED`` only): what a caller tests, not the message.

    """

    def __init__(self, check_start: bool = True):
        self.check_start = check_start
        self.status = Status.RUNNING
        self.message = self.reason = self.refusal = ''
        self.failure: Optional[Failure] = None

    def fail(self, sim, reason: str, failure: Failure):
        """Fail sim's run now, at ``sim.t``, unless it has already ended."""
        if self.status is Status.RUNNING:
            self.status, self.failure, self.reason = Status.FAILED, failure, reason
            self.message = f'at t = {sim.t:.9g} s: {reason}'
            self._refused_at_start(sim)

    def stop(self, sim, stops: list):
        """Stop sim's run as the first of stops says ((status, message) each), if any."""
        if stops and self.status is Status.RUNNING:
            self.status, self.message = stops[0]
            self.reason = self.message
            self._refused_at_start(sim)

    def _refused_at_start(self, sim):
        """Give check's line as the message of a run check refuses, ended at its start."""
        if self.check_start:
            self.refusal = start_refusal(sim)   # '' at once unless it ended in its first step
            self.message = self.refusal or self.message
