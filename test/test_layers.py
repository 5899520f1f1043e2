# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The package's layers, as the README's architecture section draws them.

core <- recording <- study <- faces (cli, plots) and ros: a module may import
only its own layer and the layers below it, and only ``cfem_ros/ros`` may
import rclpy or ROS message packages; and no modules import each other in a
circle, through any number of others. Inside the core, its subpackages are
the pipeline: fileio <- model <- scenario, engine <- run (``CORE_MAY_IMPORT``).
Every import is checked, also those inside functions.
"""

import ast
import pathlib
import subprocess
import sys

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / 'cfem_ros'

#: Each layer and the cfem_ros layers it must not import.
FORBIDDEN = {
    'core': {'recording', 'study', 'ros', 'faces'},
    'recording': {'study', 'ros', 'faces'},
    'study': {'ros', 'faces'},
    'ros': {'study', 'faces'},
    'faces': set(),   # the command line may start ROS tools (lazily)
}

#: Python packages of ROS 2 (rclpy and the message packages).
ROS_PACKAGES = {'rclpy', 'rcl_interfaces', 'geometry_msgs', 'std_msgs', 'rosgraph_msgs',
                'visualization_msgs', 'tf2_msgs', 'nav_msgs', 'builtin_interfaces'}


def layer_of(module: str) -> str:
    """Return the layer of a cfem_ros module name ('cfem_ros.core.engine.simulator' -> 'core')."""
    parts = module.split('.')
    if len(parts) > 1 and parts[1] in ('core', 'recording', 'study', 'ros'):
        return parts[1]
    return 'faces'   # cli, plots


def modules():
    for path in sorted(PACKAGE.rglob('*.py')):
        rel = path.relative_to(PACKAGE.parent).with_suffix('')
        name = '.'.join(rel.parts[:-1] if rel.name == '__init__' else rel.parts)
        yield name, path


def imported(path: pathlib.Path):
    """Yield (line, imported module name) for every import statement in a file."""
    tree = ast.parse(path.read_text(encoding='utf-8'))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f'{path}:{node.lineno}: relative import'
            if node.module == 'cfem_ros':   # from cfem_ros import x: x is a module or a name
                for alias in node.names:
                    module = PACKAGE / alias.name
                    if module.with_suffix('.py').is_file() or module.is_dir():
                        yield node.lineno, f'cfem_ros.{alias.name}'
                    else:   # a name of the package's root (lazy, imports nothing)
                        yield node.lineno, 'cfem_ros'
            else:
                yield node.lineno, node.module


def import_graph() -> dict:
    """Return each cfem_ros module's set of the cfem_ros modules it imports (itself excepted)."""
    names = dict(modules())
    graph = {}
    for name, path in names.items():
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):   # a module's names, or its submodules
                for alias in node.names:
                    sub = f'{node.module}.{alias.name}'
                    targets.add(sub if sub in names else node.module)
        graph[name] = {t for t in targets if t in names and t != name}
    return graph


def circles(graph: dict) -> list:
    """Return the strongly connected components of more than one module, each sorted."""
    names = sorted(graph)
    index = {name: i for i, name in enumerate(names)}
    edges = [(index[a], index[b]) for a in names for b in graph[a]]
    rows, cols = zip(*edges) if edges else ((), ())
    matrix = csr_matrix((np.ones(len(edges)), (rows, cols)), shape=(len(names),) * 2)
    count, labels = connected_components(matrix, directed=True, connection='strong')
    components = [[names[i] for i in np.flatnonzero(labels == c)] for c in range(count)]
    return sorted(c for c in components if len(c) > 1)


#: Each subpackage of the core and the core subpackages it may import: the model is
#: the data the scenario parser builds and the engine runs, so it sits below both;
#: ``native`` (the compiled kernel's face, and the ISA, trajectories and shape
#: distances computed with it alone) sits on the model's data, below the parser's
#: checks and the engine; the engine never reads a scenario file, the parser never
#: steps. The core's own modules (errors, rotations, the compiled ``_kernel``) are
#: below all of them.
CORE_MAY_IMPORT = {
    'fileio': set(),
    'model': {'fileio'},
    'native': {'model'},
    'scenario': {'fileio', 'model', 'native'},
    'engine': {'fileio', 'model', 'native'},
    'run': {'fileio', 'model', 'native', 'scenario', 'engine'},
}


def core_part_of(module: str):
    """Return the core subpackage of a module ('cfem_ros.core.native.kernel' -> 'engine')."""
    parts = module.split('.')
    if parts[:2] == ['cfem_ros', 'core'] and len(parts) > 3 and parts[2] in CORE_MAY_IMPORT:
        return parts[2]
    return None   # outside the core, or one of the core's own modules


def core_upward(graph: dict) -> list:
    """Return the (module, imported module) pairs of the core against CORE_MAY_IMPORT."""
    wrong = []
    for name, targets in graph.items():
        part = core_part_of(name)
        for target in targets:
            to = core_part_of(target)
            if part and to and to != part and to not in CORE_MAY_IMPORT[part]:
                wrong.append((name, target))
    return sorted(wrong)


def test_the_core_is_a_pipeline():
    found = core_upward(import_graph())
    assert not found, 'core imports against the pipeline:\n' + '\n'.join(
        f'{a} imports {b}' for a, b in found)


def test_core_upward_catches_a_wrong_way_import():
    # the check above would pass vacuously if core_upward missed one
    graph = {'cfem_ros.core.engine.dynamics': {'cfem_ros.core.run.inputs',
                                               'cfem_ros.core.model.model',
                                               'cfem_ros.core.rotations'},
             'cfem_ros.core.model.model': {'cfem_ros.core.scenario.parse'},
             'cfem_ros.core.scenario.parse': {'cfem_ros.core.model.model',
                                              'cfem_ros.core.fileio.yamlfile'},
             'cfem_ros.core.run.session': {'cfem_ros.core.engine.simulator'}}
    assert core_upward(graph) == [
        ('cfem_ros.core.engine.dynamics', 'cfem_ros.core.run.inputs'),
        ('cfem_ros.core.model.model', 'cfem_ros.core.scenario.parse')]


def test_the_layers_are_folders():
    for layer in ('core', 'recording', 'study', 'ros', 'cli'):
        assert (PACKAGE / layer / '__init__.py').is_file()
    flat = sorted(p.name for p in PACKAGE.glob('*.py'))
    assert flat == ['__init__.py', 'console.py', 'interrupts.py', 'plots.py',
                    'study_plots.py'], flat


def test_imports_only_go_down():
    wrong = []
    checked = 0
    for name, path in modules():
        layer = layer_of(name)
        for line, target in imported(path):
            checked += 1
            top = target.split('.')[0]
            if top in ROS_PACKAGES and layer != 'ros':
                wrong.append(f'{path.name}:{line} ({layer}) imports {target}')
            if top == 'cfem_ros' and target.count('.') >= 1:
                to = layer_of(target)
                if to in FORBIDDEN[layer]:
                    wrong.append(f'{name}:{line} ({layer}) imports {target} ({to})')
    assert checked > 100, 'too few imports found to be looking at the package'
    assert not wrong, 'imports against the layers:\n' + '\n'.join(wrong)


def test_layer_of_catches_an_upward_import():
    # the check above would pass vacuously if layer_of put everything in one layer
    assert FORBIDDEN[layer_of('cfem_ros.core.engine.simulator')] >= {
        layer_of('cfem_ros.ros.node'), layer_of('cfem_ros.cli'),
        layer_of('cfem_ros.recording.recorder')}


def test_no_import_circle():
    graph = import_graph()
    assert sum(len(targets) for targets in graph.values()) > 100, 'too few imports found'
    found = circles(graph)
    assert not found, 'modules importing each other in a circle:\n' + '\n'.join(
        ' <-> '.join(c) for c in found)


def test_circles_finds_a_long_circle_and_only_it():
    # the check above would pass vacuously if circles() missed one
    graph = {'a': {'b'}, 'b': {'c'}, 'c': {'a', 'd'}, 'd': set(), 'e': {'a'}}
    assert circles(graph) == [['a', 'b', 'c']]
    graph['c'] = {'d'}
    assert circles(graph) == []


def test_import_graph_sees_imports_inside_functions():
    graph = import_graph()
    assert 'cfem_ros.cli' in graph['cfem_ros.console']   # console.main imports cli lazily
    # from cfem_ros.core.native import kernel: a submodule, not the package
    assert 'cfem_ros.core.native.kernel' in graph['cfem_ros.core.engine.stepping']


@pytest.mark.parametrize('module', ['cfem_ros.core.run.session', 'cfem_ros.recording.offline',
                                    'cfem_ros.cli'])
def test_core_and_recording_run_without_ros(module):
    code = (f'import sys, {module}\n'
            'ros = sorted(m for m in sys.modules if m.split(".")[0] in %r)\n'
            'print(ros)' % (ROS_PACKAGES,))
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == '[]'


def test_the_command_line_imports_matplotlib_only_to_draw():
    code = ('import sys\n'
            'from cfem_ros import cli\n'
            'parser_ok = callable(cli.main)\n'
            'print("matplotlib" in sys.modules, parser_ok)')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ['False', 'True']
