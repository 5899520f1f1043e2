# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Draw a recording as a viewer with default settings would: /tf composed to the root, markers.

``python tools/viewer.py RUN.mcap OUT.png [--times 0 0.3 0.6]`` reads the
file with rosbags (not with cfem_ros), composes every frame to the root of
the tf tree (the display frame of RViz and Foxglove when nothing is set),
draws each body's marker (box, cylinder, sphere) and each joint's wrench
(force arrow at the wrench's frame_id) at the chosen times, z up. For
looking at, during development.
"""

import argparse
import pathlib
import sys

import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / 'test'))
from recordings import read_rosbags  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402


def transforms(message):
    """Return child -> (parent, translation, rotation xyzw) of a TFMessage."""
    return {t.child_frame_id: (t.header.frame_id,
                               np.array([t.transform.translation.x, t.transform.translation.y,
                                         t.transform.translation.z]),
                               np.array([t.transform.rotation.x, t.transform.rotation.y,
                                         t.transform.rotation.z, t.transform.rotation.w]))
            for t in message.transforms}


def compose(tree, frame):
    """Return (translation, Rotation) of frame in the root of tree, and the root's name."""
    translation, rotation = np.zeros(3), Rotation.identity()
    while frame in tree:
        parent, t, q = tree[frame]
        turn = Rotation.from_quat(q)
        translation = t + turn.apply(translation)
        rotation = turn * rotation
        frame = parent
    return translation, rotation, frame


def _box(ax, centre, rotation, size, color):
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * 0.5
    points = centre + rotation.apply(corners * size)
    for i in range(8):
        for j in range(i + 1, 8):
            if bin(i ^ j).count('1') == 1:
                ax.plot(*points[[i, j]].T, color=color, lw=1.2)


def _cylinder(ax, centre, rotation, radius, length, color):
    angles = np.linspace(0, 2 * np.pi, 25)
    for z in (-length / 2, length / 2):
        ring = np.stack([radius * np.cos(angles), radius * np.sin(angles),
                         np.full_like(angles, z)], axis=1)
        ax.plot(*(centre + rotation.apply(ring)).T, color=color, lw=1.2)
    for a in angles[::3]:
        line = np.array([[radius * np.cos(a), radius * np.sin(a), -length / 2],
                         [radius * np.cos(a), radius * np.sin(a), length / 2]])
        ax.plot(*(centre + rotation.apply(line)).T, color=color, lw=0.6)


def render(path, out, times):
    """Draw the recording at path at the given times (s from the first sample) into out."""
    messages, _ = read_rosbags(path)
    static = {}
    for topic, _, message in messages:
        if topic == '/tf_static':
            static.update(transforms(message))
    tf = {t: transforms(m) for topic, t, m in messages if topic == '/tf'}
    stamps = sorted(tf)
    markers = [(t, m) for topic, t, m in messages if topic.endswith('/markers')
               and not topic.endswith('/load_markers')]
    arrows = [(t, m) for topic, t, m in messages if topic.endswith('/load_markers')]
    fig = plt.figure(figsize=(9, 7))
    ax = fig.add_subplot(projection='3d')
    everything = []
    for when in times:
        stamp = min(stamps, key=lambda s: abs(s - stamps[0] - when * 1e9))
        tree = {**static, **tf[stamp]}
        array = [m for t, m in markers if t <= stamp][-1]
        for marker in array.markers:
            frame, turn, root = compose(tree, marker.header.frame_id)
            p, q = marker.pose.position, marker.pose.orientation
            centre = frame + turn.apply([p.x, p.y, p.z])
            rotation = turn * Rotation.from_quat([q.x, q.y, q.z, q.w])
            color = (marker.color.r, marker.color.g, marker.color.b)
            s = np.array([marker.scale.x, marker.scale.y, marker.scale.z])
            if marker.type == 1:
                _box(ax, centre, rotation, s, color)
            elif marker.type == 3:
                _cylinder(ax, centre, rotation, s[0] / 2, s[2], color)
            else:
                ax.scatter(*centre, color=color, s=30)
            if marker.ns.endswith('/bodies') and when == times[0]:
                ax.text(*centre, f' {marker.text}', fontsize=8)
            everything.append(centre)
        for marker in ([m for t, m in arrows if t <= stamp] or [None])[-1].markers \
                if arrows else ():
            if marker.type != 0 or marker.action != 0:   # arrows (DELETEALL comes first)
                continue
            origin, turn, _ = compose(tree, marker.header.frame_id)
            a, b = ([p.x, p.y, p.z] for p in marker.points)
            start, end = origin + turn.apply(a), origin + turn.apply(b)
            ax.quiver(*start, *(end - start), color='crimson', lw=2)
            ax.text(*end, f' {marker.text}', fontsize=7, color='crimson')
    everything = np.array(everything)
    middle, half = everything.mean(axis=0), np.ptp(everything, axis=0).max() / 2 + 1.5
    for setter, m in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), middle):
        setter(m - half, m + half)
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.set_zlabel('z (m), up')
    ax.set_title(f'{path}: tf root {root!r}, t = ' + ', '.join(f'{t:g}' for t in times) + ' s')
    ax.view_init(elev=8, azim=-80)
    fig.savefig(out, dpi=110)


def main(argv=None):
    """Parse the command line and render."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('recording')
    parser.add_argument('png')
    parser.add_argument('--times', type=float, nargs='+', default=[0.0, 0.3, 0.6])
    args = parser.parse_args(argv)
    render(args.recording, args.png, args.times)
    return 0


if __name__ == '__main__':
    sys.exit(main())
