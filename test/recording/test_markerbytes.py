# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""MarkerArrays encoded from templates: the bytes of mcap_ros2's encoder."""

import pathlib

from cfem_ros.core.scenario import load_scenario
from cfem_ros.recording import visuals
from cfem_ros.recording.markerbytes import MarkerArrayEncoder
from cfem_ros.recording.msgdefs import DEFINITIONS
from cfem_ros.recording.recorder import MARKERS, stamp
from hypothesis import given, settings, strategies as st
from mcap_ros2._dynamic import serialize_dynamic
import numpy as np

CONFIG = pathlib.Path(__file__).resolve().parents[2] / 'config'
ENCODE = serialize_dynamic(MARKERS, DEFINITIONS[MARKERS])[MARKERS]
MODEL = load_scenario(str(CONFIG / 'store_release_two_hooks.yaml'))
FORCE = st.floats(-1e7, 1e7, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(sendings=st.lists(st.tuples(
    st.integers(0, 2 ** 40), st.lists(st.booleans(), min_size=3, max_size=3),
    st.lists(st.tuples(FORCE, FORCE, FORCE), min_size=3, max_size=3)), min_size=1, max_size=6),
    namespace=st.sampled_from(['/cfem', '/a/much/longer/namespace']))
def test_every_sending_is_the_encoder_s_bytes(sendings, namespace):
    # one encoder for all the sendings: templates made by one are reused by the next
    encoder = MarkerArrayEncoder(ENCODE)
    for stamp_ns, active, forces in sendings:
        loads = [(k, np.array(f)) for k, (on, f) in enumerate(zip(active, forces)) if on]
        message = visuals.load_arrows(MODEL, stamp(stamp_ns), namespace, loads)
        assert encoder(message) == ENCODE(message)
        # told the kind as the recorder tells it: the joints (their lengths, not the texts)
        kind = ('arrows', namespace, tuple(k for k, _ in loads))
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
    widths = {len(m['text']) for force in (0.0, 1e-3, 7.6e3, 3.2e6)
              for m in visuals.load_arrows(MODEL, stamp(0), '/cfem',
                                           [(0, np.array([force, 0.0, 0.0]))])['markers']
              if 'text' in m}
    assert widths == {len('pylon_mount: 7.603e+03 N')}   # joint 0
