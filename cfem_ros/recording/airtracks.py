# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The air each body saw, read from a recording's ``bodies/<body>/aero/*`` topics.

SPEC section 10: per body with aero tables, four ``Vector3Stamped`` topics at
every sample (``core.engine.aero.AIR_TOPICS``): the flow (alpha, beta in deg, Mach),
the air (dynamic pressure Pa, density kg/m^3, airspeed m/s) and the force and
moment coefficients (the moments about the actual CG).
"""

from __future__ import annotations

from dataclasses import dataclass

from cfem_ros.core.engine.aero import AIR_TOPICS
from cfem_ros.recording import schema
from cfem_ros.recording.reader import decoded_messages, open_mcap
import numpy as np


@dataclass(frozen=True)
class AirTrack:
    """
    What one body's tables were read at, sample by sample.

    Attributes
    ----------
    name : str
    time : ndarray, shape (n,)
        s from the run's start.
    values : dict of str to ndarray, shape (n, 3)
        By topic name (``flow``, ``air``, ``force_coefficients``,
        ``moment_coefficients``), NaN where a sample lacks it.

    """

    name: str
    time: np.ndarray
    values: dict


def read_air(path: str, namespace: str, start_ns: int) -> dict:
    """Return body name -> AirTrack of a recording (empty if it has no aero topics)."""
    names = [name for name, _ in AIR_TOPICS]
    rows = {}
    with open_mcap(path, whole=False) as reader:
        summary = reader.get_summary()
        topics = [c.topic for c in summary.channels.values()
                  for m in [schema.AIR.pattern.match(c.topic)]
                  if m and m['ns'] == namespace and m['quantity'] in names]
        if not topics:
            return {}
        for channel, _, decoded in decoded_messages(reader, path, topics=topics):
            match = schema.AIR.pattern.match(channel.topic)
            stamp = decoded.header.stamp
            when = stamp.sec * 1_000_000_000 + stamp.nanosec
            v = decoded.vector
            rows.setdefault(match['body'], {}).setdefault(when, {})[match['quantity']] = (
                v.x, v.y, v.z)
    tracks = {}
    for body, samples in rows.items():
        stamps = sorted(samples)
        values = {name: np.array([samples[s].get(name, (np.nan,) * 3) for s in stamps],
                                 dtype=float).reshape(len(stamps), 3) for name in names}
        tracks[body] = AirTrack(name=body, time=(np.array(stamps, dtype=np.int64) - start_ns)
                                / 1e9, values=values)
    return tracks
