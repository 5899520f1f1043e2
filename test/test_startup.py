# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
What ``cfem-sim run`` imports: only what a run uses, since its start-up is its imports.

A run of a shipped scenario takes milliseconds; the process around it is
mostly imports. These tests run the command in a fresh process and list
the modules it loaded: a JIT compiler (numba, llvmlite: the core is a C++
extension), scipy, the MCAP reader, the figures, the study tools and ROS
must not be among them, while the run still records.
"""

import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: A run, then the names of the modules it loaded, one a line after a marker.
RUN = """
import sys
from cfem_ros import cli
status = cli.main(['run', sys.argv[1], '-o', sys.argv[2], '--overwrite'])
print('MODULES')
print('\\n'.join(sorted(sys.modules)))
sys.exit(status)
"""

#: Modules a run does not use, by what they are for.
UNUSED = {
    'numba': 'a JIT (the kernel is a C++ extension module)',
    'llvmlite': "numba's compiler",
    'scipy': 'only for reading and analysing recordings',
    'matplotlib': 'figures (cfem-sim plot)',
    'mcap.reader': 'reading recordings (cfem-sim info, compare, --inputs)',
    'cfem_ros.recording.analysis': 'reading recordings',
    'subprocess': 'building anything',
    'dask': 'separation studies',
    'pandas': 'separation studies',
    'rclpy': 'the ROS 2 node',
}


def run_modules(tmp_path, scenario='store_separation.yaml'):
    """Run ``cfem-sim run`` on a shipped scenario in a fresh process; return its modules."""
    out = tmp_path / 'run.mcap'
    done = subprocess.run([sys.executable, '-c', RUN, str(ROOT / 'config' / scenario),
                           str(out)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert out.stat().st_size > 10_000   # it did record
    return set(done.stdout.split('MODULES\n', 1)[1].split())


def test_a_run_imports_only_what_it_uses(tmp_path):
    modules = run_modules(tmp_path)
    assert {'cfem_ros.core.native.kernel', 'cfem_ros.core._kernel', 'cfem_ros.recording.recorder',
            'numpy', 'yaml'} <= modules
    unused = {name: why for name, why in UNUSED.items() if name in modules}
    assert not unused, f'a run imported modules it does not use: {unused}'


def test_runs_of_every_paper_scenario_import_no_more(tmp_path):
    # bodies drawn as their inertia's box (no shape given), ejectors, an aero table,
    # a carrier flying a pull-up: all of it runs without the modules a run does not use
    for scenario in ('double_pendulum.yaml', 'fixed_joint_spin.yaml',
                     'store_separation_ejectors.yaml', 'store_separation_aero.yaml',
                     'store_release_from_pullup.yaml'):
        used = run_modules(tmp_path, scenario) & set(UNUSED)
        assert not used, (scenario, used)
