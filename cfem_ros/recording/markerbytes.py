# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
A recording's MarkerArrays (bodies, joint-load arrows), encoded from templates.

``mcap_ros2``'s encoder walks a MarkerArray's definition field by field: about
1.7 ms for the two arrows of the double pendulum, more for the bodies, and a
recording holds ten sendings of the arrows and one of the bodies per simulated
second, more than the rest of a 100 Hz recording. From one sending to the
next mostly the stamps change, and the arrows' points and the numbers in their
texts; so each kind of sending (everything else of its markers, the number of
points and the byte lengths of the texts) is encoded once by ``mcap_ros2``
with marker values in those places, and every sending of that kind copies
those bytes and writes its own values where the markers landed. The bytes are
the encoder's (``test/recording/test_markerbytes.py`` compares them).
"""

import struct

_STAMP = struct.Struct('<iI')
_POINT = struct.Struct('<3d')
_TEXT_MARK = 0x7F
#: Templates by (encoder, kind), shared by the recordings of a process (a sweep's runs
#: share their kinds); emptied when it holds this many.
_TEMPLATES = {}
_MOST = 4096


class MarkerArrayEncoder:
    """
    Encode MarkerArray messages (dicts) as ``mcap_ros2`` does, from templates.

    encode: ``mcap_ros2``'s encoder of a MarkerArray (a dict to bytes).
    """

    def __init__(self, encode):
        self.encode = encode

    def __call__(self, message: dict, kind=None) -> bytes:
        """
        Return the CDR bytes of message, as ``encode(message)`` would.

        kind: a hashable value that, with the byte lengths of the texts,
        determines everything of the message but its stamps, points and texts
        (e.g. the arrows' joints); None: found from the message (slower).
        """
        markers = message['markers']
        texts = [m.get('text', '').encode() for m in markers]
        key = (self.encode, repr([_kind(m, text) for m, text in zip(markers, texts)])
               if kind is None else (kind, tuple(map(len, texts))))
        template = _TEMPLATES.get(key)
        if template is None:
            if len(_TEMPLATES) >= _MOST:
                _TEMPLATES.clear()
            template = _TEMPLATES[key] = self._template(message, texts)
        data, stamps, points, text_at = template
        out = bytearray(data)
        for marker, at in zip(markers, stamps):
            stamp = marker['header']['stamp']
            _STAMP.pack_into(out, at, stamp['sec'], stamp['nanosec'])
        for marker, places in zip(markers, points):
            for point, at in zip(marker.get('points', ()), places):
                _POINT.pack_into(out, at, point['x'], point['y'], point['z'])
        for text, at in zip(texts, text_at):
            if text:
                out[at:at + len(text)] = text
        return bytes(out)

    def _template(self, message: dict, texts: list) -> tuple:
        """Encode message with marker values; return (bytes, where they landed)."""
        marked = {'markers': []}
        for i, (marker, text) in enumerate(zip(message['markers'], texts)):
            copy = dict(marker, header=dict(marker['header'],
                                            stamp={'sec': 0x5A000000 + i,
                                                   'nanosec': 0x3B000000 + i}))
            copy['points'] = [dict(zip('xyz', _marks(i, p))) for p in range(len(
                marker.get('points', ())))]
            if text:
                copy['text'] = chr(_TEXT_MARK) * len(text)
            marked['markers'].append(copy)
        data = self.encode(marked)
        stamps, points, text_at = [], [], []
        for i, (copy, text) in enumerate(zip(marked['markers'], texts)):
            stamp = copy['header']['stamp']
            stamps.append(data.index(_STAMP.pack(stamp['sec'], stamp['nanosec'])))
            places = [data.index(_POINT.pack(*_marks(i, p))) for p in range(len(copy['points']))]
            points.append(places)
            text_at.append(_text_place(data, stamps[-1], len(text)) if text else None)
        return data, stamps, points, text_at


def _kind(marker: dict, text: bytes) -> dict:
    """Return the marker without what a template leaves to each sending."""
    out = dict(marker, header=dict(marker['header'], stamp=None), text=len(text))
    out['points'] = len(marker.get('points', ()))
    return out


def _marks(marker: int, point: int) -> tuple:
    """Three float64 values that occur nowhere else in a marked message."""
    return tuple(1.0 + 2.0 ** -40 * (1 + 3 * (16 * marker + point) + c) for c in range(3))


def _text_place(data: bytes, start: int, length: int) -> int:
    """Where a marked text of this length begins, after its marker's stamp."""
    pattern = struct.pack('<I', length + 1) + bytes([_TEXT_MARK]) * length + b'\0'
    return data.index(pattern, start) + 4
