# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The simulation_interfaces types the node serves are the standard ones, byte for byte.

ROS 2 (Iron on) checks a type by its RIHS01 hash, computed from its fields
alone: equal hashes, equal wire format. The package built from
``interfaces/simulation_interfaces`` (``make interfaces``) must give the
hashes of the published Kilted 1.6.1 package. Five are known in full (from
the published package's generated C code); for the other five the published
start and end digits are compared (the issue lists them; no full value was
to be found). The hashes are read from the build's type descriptions and
must also be the bytes its C type support library returns.
"""

import json
import pathlib

import pytest
import simulation_interfaces

#: type -> the published RIHS01 hash: 64 hex digits, or (start, end) where only those are known
PUBLISHED = {
    'srv/GetSimulatorFeatures': ('abb9439c', 'a794'),
    'srv/GetSimulationState':
        '3362dcebee4b1afebbf9c4beee5c79c1455385aded62092a892d61fde8644f30',
    'srv/SetSimulationState': ('a868b916', 'cb30'),
    'srv/StepSimulation': '913fe0653690ce6bf8f09f316e6a626747012e9fca31e26719910d417aa8565c',
    'srv/ResetSimulation': '4ce285d7ff9b8ac70dcc95161f32bf54c05a6f4b13427990e41ab40c36c39646',
    'srv/GetEntities': 'cb90004c48cd50f37732fb008e22c34c261dd680a723bf0f85d8437ea4498bf7',
    'srv/GetEntityState': ('749c91f2', '7fb5'),
    'srv/GetEntitiesStates':
        '0a76170d0c1c90e1eaf805cfab78ea801d1f82df309a28c1f0fae4b570f19754',
    'srv/SetEntityState': ('ca210e7d', 'ee5e'),
    'action/SimulateSteps': ('f0837c89', '67eb'),
}


def _prefix() -> pathlib.Path:
    """Return the install prefix of the simulation_interfaces the node imports."""
    here = pathlib.Path(simulation_interfaces.__file__).resolve()
    for parent in here.parents:
        if (parent / 'share' / 'simulation_interfaces' / 'package.xml').is_file():
            return parent
    raise AssertionError(f'no share/simulation_interfaces above {here}')


def _built_hash(name: str) -> str:
    description = json.loads(
        (_prefix() / 'share' / 'simulation_interfaces' / f'{name}.json').read_text())
    full = f'simulation_interfaces/{name}'
    (value,) = [h['hash_string'] for h in description['type_hashes'] if h['type_name'] == full]
    assert value.startswith('RIHS01_') and len(value) == 7 + 64
    return value[7:]


@pytest.mark.parametrize('name', sorted(PUBLISHED))
def test_the_built_types_have_the_published_hashes(name):
    built, published = _built_hash(name), PUBLISHED[name]
    if isinstance(published, str):
        assert built == published
    else:
        assert built.startswith(published[0]) and built.endswith(published[1]), built


def test_the_c_type_support_holds_those_hashes():
    library = next((_prefix() / 'lib').glob('libsimulation_interfaces__rosidl_generator_c.so'))
    data = library.read_bytes()
    for name in PUBLISHED:
        assert bytes.fromhex(_built_hash(name)) in data, name
