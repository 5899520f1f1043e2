# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Every module, file and function that a comment, docstring or guide page names exists.

What is shown is what is true (STYLE.md, habit 14): a comment that sends the
reader to ``kernel.py's _hinge_motion`` or a guide page that lists a module
which moved is a wrong turn. Resolved here, statically (no import but the
extension's), in every package, test and benchmark source, every C++ source
and every guide page:

- a dotted path ``cfem_ros.x.y`` (anywhere in the text, strings included: an
  error message names it to a user) down to its first name past the module;
- a path ``cfem_ros/x/y.py``, ``test/...``, ``benchmarks/...``,
  ``cpp/name.cpp``, ``docs/guide/page.md`` (the same);
- in comments, docstrings and guide pages: ``module.name`` for a module's
  short name (``kernel.views``, ``loads.set_time``: a name of a Python module
  or C++ file of that name), ``Class.member`` for a class of the package
  (``Simulator.advance_to``, its bases' members included), ``file.py's name``
  and ``name in file.py``.
"""

import ast
import functools
import io
import pathlib
import re
import tokenize

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGE = ROOT / 'cfem_ros'
CPP = PACKAGE / 'core' / 'cpp'
#: Python sources whose comments and docstrings are read.
SOURCES = ('cfem_ros', 'test', 'benchmarks')
#: What follows a dot in a file name, not a name in a module.
EXTENSIONS = {'py', 'cpp', 'hpp', 'h', 'yaml', 'yml', 'md', 'json', 'csv', 'mcap', 'txt',
              'html', 'png', 'svg', 'parquet', 'so', 'pyd', 'xml', 'cfg', 'toml', 'in', 'npz',
              'npy', 'db3', 'msg', 'srv', 'action', 'launch', 'rst', 'log', 'pdf', 'ini',
              'sh', 'gz', 'zip', 'pkl', 'idl', 'dat', 'tsv', 'xlsx', 'ipynb'}

DOTTED = re.compile(r'(?<![\w.])cfem_ros(?:\.[A-Za-z_]\w*)+')
PATH = re.compile(r'(?<![\w./-])((?:cfem_ros|test|benchmarks|docs/guide)/[\w./-]*\w\.(?:py|md)'
                  r'|cpp/\w+\.(?:cpp|hpp))\b')
SHORT = re.compile(r'(?<![\w.:/-])([A-Za-z_]\w*)\.([A-Za-z_]\w*)(?![\w*-])(?!\.py\b)')
#: Short names that are also the project's variables, attributes and key-path roots in
#: prose (``bodies.store.mass``, ``flight.mach``, ``run.joints``, ``node.run``): there a
#: ``word.name`` is not a module's name, and is not read as one.
NOT_MODULES = {'bodies', 'joints', 'flight', 'aero', 'run', 'sweep', 'spec', 'model', 'node',
               'criteria', 'measured', 'metrics', 'layout', 'wrenches', 'contacts', 'braces',
               'releases', 'outputs', 'events', 'session', 'inputs', 'labels', 'windows',
               'loads', 'motion', 'shapes', 'carrier', 'fit', 'study', 'report', 'results'}
BARE_FILE = re.compile(r'(?<![\w./-])(\w+\.(?:py|cpp|hpp))\b')
FILE_NAME = re.compile(r'(?<![\w./-])(\w+)\.py(?:``|`)?\'s ``?(\w+)')
NAME_IN_FILE = re.compile(r'``?(\w+)(?:\(\))?``? in ``?(?:[\w/]*/)?(\w+)\.py\b')


def _python_files():
    for folder in SOURCES:
        # this file names stale paths on purpose (the resolver's own test)
        yield from sorted(p for p in (ROOT / folder).rglob('*.py') if p != pathlib.Path(__file__))


def _cpp_files():
    return sorted(p for p in CPP.iterdir() if p.suffix in ('.cpp', '.hpp'))


def _guide_pages():
    return sorted((ROOT / 'docs' / 'guide').glob('*.md'))


@functools.lru_cache(maxsize=None)
def _tree(path: pathlib.Path):
    return ast.parse(path.read_text(encoding='utf-8'))


def _members(body) -> set:
    """Return the names a module or class body binds (self.x in its methods included)."""
    names = set()
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update((a.asname or a.name).split('.')[0] for a in node.names)
        elif isinstance(node, (ast.If, ast.Try, ast.With)):
            inner = list(node.body) + list(getattr(node, 'orelse', []))
            for handler in getattr(node, 'handlers', []):
                inner += handler.body
            names |= _members(inner)
        for target in _targets(node):
            names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
        if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id in ('_HOMES', '__all__') for t in node.targets):
            # names loaded on first use (PEP 562's __getattr__)
            names.update(k.value for k in ast.walk(node.value)
                         if isinstance(k, ast.Constant) and isinstance(k.value, str))
    return names


def _targets(node):
    if isinstance(node, ast.Assign):
        return node.targets
    if isinstance(node, (ast.AnnAssign, ast.AugAssign)):
        return [node.target]
    return []


@functools.lru_cache(maxsize=None)
def _module_names(path: pathlib.Path) -> frozenset:
    return frozenset(_members(_tree(path).body))


@functools.lru_cache(maxsize=None)
def _classes() -> dict:
    """Return {class name: [(its bases' names, the names it binds)]} of the package."""
    found = {}
    for path in PACKAGE.rglob('*.py'):
        for node in ast.walk(_tree(path)):
            if not isinstance(node, ast.ClassDef):
                continue
            names = _members(node.body)
            for sub in ast.walk(node):
                if isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Name) \
                        and sub.value.id in ('self', 'cls') \
                        and isinstance(sub.ctx, ast.Store):
                    names.add(sub.attr)
            bases = [b.id if isinstance(b, ast.Name) else getattr(b, 'attr', '')
                     for b in node.bases]
            found.setdefault(node.name, []).append((bases, names))
    return found


def _class_has(name: str, member: str, seen=()) -> bool:
    for bases, names in _classes().get(name, ()):
        if member in names:
            return True
        if any(_class_has(b, member, seen + (name,)) for b in bases if b not in seen):
            return True
    return False


@functools.lru_cache(maxsize=None)
def _short_modules() -> dict:
    """Return {short name: [Python module files and C++ sources of that name]}."""
    found = {}
    for path in PACKAGE.rglob('*.py'):
        stem = path.parent.name if path.name == '__init__.py' else path.stem
        found.setdefault(stem, []).append(path)
    for folder in ('test', 'benchmarks'):
        for path in (ROOT / folder).rglob('*.py'):
            found.setdefault(path.stem, []).append(path)
    for path in _cpp_files():
        found.setdefault(path.stem, []).append(path)
    return found


@functools.lru_cache(maxsize=None)
def _file_names() -> frozenset:
    """Return the names of the repository's Python and C++ files (a file named alone)."""
    found = {p.name for p in ROOT.glob('*.py')} | {p.name for p in _cpp_files()}
    for folder in SOURCES + ('docs',):
        found |= {p.name for p in (ROOT / folder).rglob('*.py')}
    return frozenset(found)


def _defined(path: pathlib.Path) -> set:
    """Return the names a module defines itself (not those it imports)."""
    names = set()
    for node in _tree(path).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        for target in _targets(node):
            names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
    return names


def package_modules_named(init: pathlib.Path) -> list:
    """
    Return the ``names`` of a package's docstring that are neither its modules nor its names.

    A package's docstring lists its modules (``Modules: ``simulator``, ...``): one
    that moved elsewhere, or was never there, is a stale name. Accepted: a module or
    subpackage of the package, a name its modules define, a module of ``cfem_ros``
    itself (the faces ``cli``, ``plots``).
    """
    folder = init.parent
    doc = ast.get_docstring(_tree(init)) or ''
    known = set()
    for place in (folder, PACKAGE):
        known |= {p.stem for p in place.glob('*.py')}
        known |= {p.parent.name for p in place.glob('*/__init__.py')}
    known |= {p.name.split('.')[0] for p in folder.glob('*.so')}   # the extension
    for path in folder.glob('*.py'):
        known |= _defined(path)
    return [name for name in re.findall(r'``([a-z_][a-z0-9_]*)``', doc) if name not in known]


@functools.lru_cache(maxsize=None)
def _cpp_text(path: pathlib.Path) -> str:
    return path.read_text(encoding='utf-8')


def _in_module(path: pathlib.Path, name: str) -> bool:
    """Return whether the module (or C++ source) at path defines name."""
    if path.suffix == '.py':
        if name in _module_names(path):
            return True
        if path.name == '__init__.py':
            # a package: its modules, and the names they define (``model.Wrench``)
            folder = path.parent
            if (folder / f'{name}.py').exists() or (folder / name / '__init__.py').exists():
                return True
            return any(name in _module_names(p) for p in folder.glob('*.py'))
        return False
    text = _cpp_text(path)
    return re.search(rf'\b{re.escape(name)}\b', text) is not None


def _extension_has(parts) -> bool:
    from cfem_ros.core import _kernel
    here = _kernel
    for part in parts[:2]:
        if not hasattr(here, part):
            return False
        here = getattr(here, part)
    return True


@functools.lru_cache(maxsize=None)
def _loggers() -> frozenset:
    """Return the package's logger names (``cfem_ros.sweep.runs``: not module paths)."""
    found = set()
    for path in PACKAGE.rglob('*.py'):
        for match in re.finditer(r'getLogger\(\s*f?[\'"](cfem_ros[\w.]*?)\.?[{\'"]',
                                 path.read_text(encoding='utf-8')):
            found.add(match.group(1))
    return frozenset(found)


def resolve_dotted(dotted: str) -> bool:
    """Return whether cfem_ros.x.y... is a module and its first name past it exists."""
    if dotted in _loggers():
        return True
    parts = dotted.split('.')
    if parts[-1].startswith('__'):
        parts = parts[:-1]   # cfem_ros.__file__, a module's __doc__
    here = ROOT
    for k, part in enumerate(parts):
        if part == '_kernel' and here == PACKAGE / 'core':
            return _extension_has(parts[k + 1:])
        if (here / part / '__init__.py').exists():
            here = here / part
            continue
        if (here / f'{part}.py').exists():
            module = here / f'{part}.py'
            return k + 1 == len(parts) or _in_module(module, parts[k + 1])
        # a name of the package's __init__ (or not there at all)
        init = here / '__init__.py'
        return k > 0 and init.exists() and _in_module(init, part)
    return True


def resolve_path(path: str) -> bool:
    """Return whether a file named by its path from the root (or cpp/) exists."""
    if path.startswith('cpp/'):
        return (CPP / path[4:]).exists()
    return (ROOT / path).exists()


def resolve_short(module: str, name: str):
    """Return True, False, or None when module is not a module's or class's name."""
    homes = _short_modules().get(module)
    if module in _classes():
        if _class_has(module, name) or (homes and any(_in_module(p, name) for p in homes)):
            return True
        return False
    if not homes:
        return None
    return any(_in_module(p, name) for p in homes)


# ------------------------------------------------------------------ the texts read

def _python_prose(path: pathlib.Path) -> list:
    """Return [(line, text)] of a Python file's comments and docstrings (lone strings)."""
    found = []
    before = tokenize.NEWLINE
    text = path.read_text(encoding='utf-8')
    for token in tokenize.generate_tokens(io.StringIO(text).readline):
        if token.type == tokenize.COMMENT:
            found.append((token.start[0], token.string))
        elif token.type == tokenize.STRING and before in (tokenize.NEWLINE, tokenize.INDENT,
                                                          tokenize.DEDENT):
            found.append((token.start[0], token.string))
        if token.type not in (tokenize.COMMENT, tokenize.NL):
            before = token.type
    return found


def _cpp_prose(path: pathlib.Path) -> list:
    """Return [(line, text)] of a C++ file's comments."""
    found = []
    text = path.read_text(encoding='utf-8')
    for match in re.finditer(r'//[^\n]*|/\*.*?\*/', text, re.S):
        found.append((text.count('\n', 0, match.start()) + 1, match.group()))
    return found


def _texts():
    """Yield (file, line, text, prose): every text read, prose if comment, docstring or page."""
    for path in _python_files():
        yield path, 1, path.read_text(encoding='utf-8'), False
        for line, text in _python_prose(path):
            yield path, line, text, True
    for path in _cpp_files():
        yield path, 1, path.read_text(encoding='utf-8'), False
        for line, text in _cpp_prose(path):
            yield path, line, text, True
    for path in _guide_pages():
        yield path, 1, path.read_text(encoding='utf-8'), True


def _line(text: str, offset: int, first: int) -> int:
    return first + text.count('\n', 0, offset)


def stale_names() -> list:
    """Return 'file:line: name (why)' for every name that does not resolve."""
    stale = set()
    for init in sorted(PACKAGE.rglob('__init__.py')):
        for name in package_modules_named(init):
            stale.add(f'{init.relative_to(ROOT)}: ``{name}`` (not a module of the package)')
    for path, first, text, prose in _texts():
        where = path.relative_to(ROOT)
        for match in DOTTED.finditer(text):
            if not resolve_dotted(match.group()):
                stale.add(f'{where}:{_line(text, match.start(), first)}: {match.group()}')
        for match in PATH.finditer(text):
            if not resolve_path(match.group(1)):
                stale.add(f'{where}:{_line(text, match.start(), first)}: {match.group(1)} '
                          '(no such file)')
        if not prose:
            continue
        for match in SHORT.finditer(text):
            module, name = match.groups()
            if name in EXTENSIONS or module in NOT_MODULES or module in ('self', 'cls'):
                continue
            if resolve_short(module, name) is False:
                stale.add(f'{where}:{_line(text, match.start(), first)}: {module}.{name}')
        for match in BARE_FILE.finditer(text):
            if match.group(1) not in _file_names():
                stale.add(f'{where}:{_line(text, match.start(), first)}: {match.group(1)} '
                          '(no such file)')
        for pattern, order in ((FILE_NAME, (0, 1)), (NAME_IN_FILE, (1, 0))):
            for match in pattern.finditer(text):
                module, name = (match.group(1 + order[0]), match.group(1 + order[1]))
                homes = [p for p in _short_modules().get(module, ()) if p.suffix == '.py']
                if not homes:
                    stale.add(f'{where}:{_line(text, match.start(), first)}: {module}.py '
                              '(no such file)')
                elif not any(_in_module(p, name) for p in homes):
                    stale.add(f'{where}:{_line(text, match.start(), first)}: {name} in '
                              f'{module}.py')
    return sorted(stale)


@pytest.mark.linter
def test_every_named_module_file_and_function_exists():
    stale = stale_names()
    assert not stale, 'names that do not resolve:\n' + '\n'.join(stale)


def test_the_resolver_finds_what_is_there_and_not_what_is_not():
    # the resolver itself: a test that passes on everything would hide every stale name
    assert resolve_dotted('cfem_ros.core.native.kernel.views')
    assert resolve_dotted('cfem_ros.core._kernel.testing.rk4_step')
    assert resolve_dotted('cfem_ros.Simulator')
    assert not resolve_dotted('cfem_ros.core.aeropack.pack')     # moved to core.engine
    assert not resolve_dotted('cfem_ros.core.native.kernel._hinge_motion')
    assert not resolve_dotted('cfem_ros.core._kernel.rk4_step')   # in testing
    assert resolve_path('cfem_ros/core/engine/loads.py') and resolve_path('cpp/treesolve.cpp')
    assert not resolve_path('cpp/solve.cpp')
    assert resolve_short('kernel', 'views') and resolve_short('Simulator', 'advance_to')
    assert resolve_short('loads', 'sample_applied')                # cpp/loads.cpp
    assert resolve_short('kernel', '_eliminate_one') is False
    assert resolve_short('numpy', 'ascontiguousarray') is None     # not the package's
