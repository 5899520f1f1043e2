# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""MarkerArrays encoded from templates: the bytes of mcap_ros2's encoder."""

import pathlib

from cfem_ros.core.engine.simulator import Simulator
from cfem_ros.core.scenario.parse import load_scenario
from cfem_ros.recording import loadarrows, visuals
from cfem_ros.recording.markerbytes import MarkerArrayEncoder
from cfem_ros.recording.msgdefs import DEFINITIONS
from cfem_ros.recording.recorder import stamp
from cfem_ros.recording.schema import MARKERS_TYPE
from hypothesis import given, settings, strategies as st
from mcap_ros2._dynamic import serialize_dynamic
import numpy as np

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
ENCODE = serialize_dynamic(MARKERS_TYPE, DEFINITIONS[MARKERS_TYPE])[MARKERS_TYPE]
MODEL = load_scenario(str(CONFIG / 'store_release_two_hooks.yaml'))
FORCE = st.floats(-1e7, 1e7, allow_nan=False)


SOURCES = Simulator(MODEL).applied_sources   # the ejectors, their reactions, aero


def _row(active, forces):
    """Return a sample of the two-hook model at rest with these joints' and sources' forces."""
    row = np.zeros(13 * len(MODEL.bodies) + 6 * len(active) + 6 * len(SOURCES))
    row[6:13 * len(MODEL.bodies):13] = 1.0   # quaternions w
    first = 13 * len(MODEL.bodies)
    for i, force in enumerate(forces[:len(active) + len(SOURCES)]):
        row[first + 6 * i:first + 6 * i + 3] = force
    return row


@settings(max_examples=60, deadline=None)
@given(sendings=st.lists(st.tuples(
    st.integers(0, 2 ** 40), st.lists(st.booleans(), min_size=3, max_size=3),
    st.lists(st.tuples(FORCE, FORCE, FORCE), min_size=8, max_size=8)), min_size=1, max_size=6),
    namespace=st.sampled_from(['/cfem', '/a/much/longer/namespace']))
def test_every_sending_is_the_encoder_s_bytes(sendings, namespace):
    # one encoder for all the sendings: templates made by one are reused by the next
    encoder = MarkerArrayEncoder(ENCODE)
    arrows = loadarrows.LoadArrows(MODEL, namespace, SOURCES)
    held = np.zeros((len(MODEL.bodies), 10))
    for stamp_ns, active, forces in sendings:
        joints = tuple(k for k, on in enumerate(active) if on)
        held[2, :3] = forces[-1]   # an input on the store
        message, kind = arrows.message(stamp(stamp_ns), _row(joints, forces), joints, held)
        assert encoder(message) == ENCODE(message)
        # told the kind as the recorder tells it (the texts' lengths are added)
        assert encoder(message, kind=kind) == ENCODE(message)


def test_the_bodies_markers_follow_releases_and_contacts():
    # the same stamps and frames, but colours and a contact marker that change: other kinds
    encoder = MarkerArrayEncoder(ENCODE)
    contact = {'event': 'contact', 'time': 0.5, 'bodies': ['store', 'pylon'],
               'point': [0.1, 0.0, -0.3]}
    for k, (released, contacts) in enumerate([(set(), []), ({'fwd_hook'}, []),
                                              ({'fwd_hook', 'aft_hook'}, [contact]),
                                              (set(), [])]):
        message = visuals.markers(MODEL, stamp(10 ** 9 * k + 7), '/cfem', released, contacts)
        assert encoder(message) == ENCODE(message)


def test_an_arrow_s_text_is_as_wide_for_every_force():
    arrows = loadarrows.LoadArrows(MODEL, '/cfem', SOURCES)
    widths = set()
    for force in (1e-3, 7.6e3, 3.2e6):
        message, _ = arrows.message(stamp(0), _row((0,), [(force, 0.0, 0.0)]), (0,),
                                    np.zeros((len(MODEL.bodies), 10)))
        widths |= {len(m['text']) for m in message['markers'] if 'text' in m}
    assert widths == {len('pylon_mount joint: 7.600e+03 N, 1 m = 5e+03 N')}
