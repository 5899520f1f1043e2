# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What a run's status and its events can be, each with its one text form, and an event as a line.

``Status`` and ``Event`` are enums whose members are also ``str``: the text
form is what recordings (the ``events`` topic's JSON), tables (the
``status`` column) and printed lines have always held, so a member writes,
compares and hashes as its text does (``Status.OK == 'ok'``, and a status
read back from a table is found in a set of members). ``Failure`` is why a
run failed, carried by ``NumericalFailure`` and kept by the simulator
(``Simulator.failure``), so that a caller tells failures apart by kind,
never by reading the message. ``describe_event`` is the one place an event
becomes a line for a user (``cfem-sim run``, ``cfem-sim info``, the node's
log), ``contact_label`` the label of a contact in the 3D view.
"""

from __future__ import annotations

import enum

import numpy as np


class TextEnum(str, enum.Enum):
    """An enum member that is its text form wherever a string goes (format, hash, JSON)."""

    def __str__(self) -> str:
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)

    # a member hashes as its text (Enum hashes by name), so that text read back
    # from a file is found in a set or dict of members and the other way round
    __hash__ = str.__hash__


class Status(TextEnum):
    """
    A run's status (``Simulator.status``) and a study row's (SPEC sections 6, 8, 10, 12).

    A simulator is ``RUNNING`` until it fails (``FAILED``) or a watch stops
    it (``CONTACT``, ``AERO_OUTSIDE``); a study row is ``OK`` for a run that
    reached its duration, or ``INVALID`` for a draw the scenario's checks
    refuse (not run).
    """

    RUNNING = 'running'
    OK = 'ok'
    FAILED = 'failed'
    CONTACT = 'contact'
    AERO_OUTSIDE = 'aero_outside'
    INVALID = 'invalid'

    @property
    def stopped_by_scenario(self) -> bool:
        """Tell whether the run ended early because the scenario says to stop there."""
        return self in STOPS


#: The statuses of a run its scenario stops (``on_contact: stop``, ``outside: stop``).
STOPS = frozenset({Status.CONTACT, Status.AERO_OUTSIDE})


class Event(TextEnum):
    """The kind of an event: its ``"event"`` key (SPEC sections 3, 7, 8, 10, 11)."""

    RELEASE = 'release'
    STROKE_END = 'stroke_end'
    BRACE_CONTACT = 'brace_contact'
    CONTACT = 'contact'
    AERO_OUTSIDE = 'aero_outside'
    AERO_INSIDE = 'aero_inside'
    ATMOSPHERE_OUTSIDE = 'atmosphere_outside'
    ATMOSPHERE_INSIDE = 'atmosphere_inside'
    # the node's (runcontrol.py) and a failed run's
    PAUSE = 'pause'
    PLAY = 'play'
    STEP = 'step'
    RESET = 'reset'
    SET_STATE = 'set_state'
    ERROR = 'error'
    # a reader's stand-in for a message of the events topic that is not JSON
    UNPARSED = 'unparsed'


#: The events that start or end a load (``load_states``; the viewers' arrows, SPEC section 4).
LOAD_EVENTS = frozenset({Event.RELEASE, Event.STROKE_END, Event.BRACE_CONTACT})
#: The events of leaving an aero table's range and of coming back.
AERO_EVENTS = (Event.AERO_OUTSIDE, Event.AERO_INSIDE)
#: The events of the node's run control (``ros.runcontrol``), told with their other keys.
CONTROL_EVENTS = frozenset({Event.PAUSE, Event.PLAY, Event.STEP, Event.RESET, Event.SET_STATE})


class Failure(TextEnum):
    """
    Why a run failed (``NumericalFailure.failure``, ``Simulator.failure``).

    The failure's message says it to a user; this says it to a caller.
    """

    NOT_FINITE = 'not_finite'
    SINGULAR = 'singular'
    LOADS_NOT_FINITE = 'loads_not_finite'
    DIVERGED = 'diverged'
    OTHER = 'other'


def kind(event: dict):
    """Return an event's kind: an ``Event``, or its text if no kind has it (a newer file's)."""
    text = event.get('event')
    try:
        return Event(text)
    except ValueError:
        return text


def describe_event(event: dict) -> str:
    """Return one line for a user about an event (``run``, ``info``, the node)."""
    what = kind(event)
    when = f"t = {event['time']:.9f} s"
    if what is Event.RELEASE:
        group = f"; group {event['group']}" if event.get('group') else ''
        return f"release {event['joint']} at {when} ({event['cause']}{group})"
    if what is Event.STROKE_END:
        u, v, w = event['velocity']
        p, q, r = event['rates']
        seen = event.get('reacts_on', 'the world')
        p, q, r = np.degrees([p, q, r])   # rates as a person reads them (SPEC 15): deg/s only
        return (f"stroke end {event['wrench']} at {when}: {event['body']} relative to {seen}, "
                f'body axes: u, v, w = {u:.4f}, {v:.4f}, {w:.4f} m/s; p, q, r = {p:.2f}, '
                f'{q:.2f}, {r:.2f} deg/s')
    if what is Event.ATMOSPHERE_OUTSIDE:
        return (f"atmosphere_outside {event['body']} at {when}: beyond {event['altitude']:g} "
                f"m, the standard atmosphere's end (between t = {event['inside_at']:.9g} "
                f"and {event['seen_at']:.9g} s); beyond, the air is its last layer "
                'continued')
    if what is Event.ATMOSPHERE_INSIDE:
        return (f"atmosphere_inside {event['body']} at {when}: back within "
                f"[{event['low']:g}, {event['high']:g}] m")
    if what in AERO_EVENTS:
        where = 'outside' if what is Event.AERO_OUTSIDE else 'back inside'
        return (f"{what} {event['body']} at {when}: {event['axis']} = {event['value']:.6g}, "
                f"{where} [{event['low']:.6g}, {event['high']:.6g}]")
    if what is Event.BRACE_CONTACT:
        touch = 'touches again' if event['contact'] else 'lets go'
        return f"brace {event['brace']} {touch} at {when}"
    if what is Event.CONTACT:
        a, b = event['bodies']
        x, y, z = event['point']
        return (f'contact {a} {b} at {when}, point [{x:.6g}, {y:.6g}, {z:.6g}] m '
                f'(world){contact_parts(event)}')
    if what in CONTROL_EVENTS:
        details = ', '.join(f'{k} {v}' for k, v in event.items() if k not in ('event', 'time'))
        return f"{what} at t = {event['time']:.9g} s" + (f' ({details})' if details else '')
    return f'{what} at {when}'


def contact_label(event: dict) -> str:
    """Return the short label of a contact's marker in the 3D view (recorded with the scene)."""
    return f'contact {" ".join(event["bodies"])} t={event["time"]:.6f} s'


def contact_parts(event: dict) -> str:
    """Return the parts of the two shapes that touched (0 for a convex shape), for a line."""
    parts = event.get('parts')
    return f', parts {parts[0]} and {parts[1]}' if parts and len(parts) == 2 else ''
