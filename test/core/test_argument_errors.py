# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""Values the package refuses are ``ArgumentError``s: a ``CfemError`` and a ``ValueError``."""

from cfem_ros.core.errors import ArgumentError, CfemError
from cfem_ros.core.fileio.instants import instant_ns
from cfem_ros.core.model.shapes import read_mesh_vertices
from cfem_ros.recording.carriage import parse_point
from cfem_ros.study.confidence import clopper_pearson, runs_needed
import pytest


@pytest.mark.parametrize('call, shown', [
    (lambda: instant_ns('2026-03-14T09:30:00'), "'2026-03-14T09:30:00'"),
    (lambda: instant_ns(1.5), '1.5'),
    (lambda: parse_point('[1, 2]'), "'[1, 2]'"),
    (lambda: parse_point([0.0, float('nan'), 0.0]), 'nan'),
    (lambda: clopper_pearson(5, 3), 'failures 5 of runs 3'),
    (lambda: clopper_pearson(0, 3, level=1.5), '1.5'),
    (lambda: runs_needed(1.0), 'success probability 1.0'),
])
def test_a_refused_value_is_an_argument_error_naming_it(call, shown):
    with pytest.raises(ArgumentError) as caught:
        call()
    assert isinstance(caught.value, CfemError) and isinstance(caught.value, ValueError)
    assert shown in str(caught.value)   # the value refused, as given


def test_a_mesh_file_of_another_kind_is_refused(tmp_path):
    path = tmp_path / 'part.ply'
    path.write_text('ply\n')
    with pytest.raises(ArgumentError, match='not an .stl or .obj file'):
        read_mesh_vertices(str(path))
    path = tmp_path / 'part.stl'
    path.write_text('solid nothing\nendsolid\n')
    with pytest.raises(ArgumentError, match='no vertices'):
        read_mesh_vertices(str(path))
