# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Every scenario and sweep written in the SPEC, the README and the guide runs.

A YAML block that is a whole scenario (it has ``bodies``) is checked and run
by ``cfem-sim run`` for a short time; a whole sweep (``scenario`` and
``vary``) is loaded with its base scenario resolved where the page says it
lies, and a few of its runs are done, each of which must succeed. An excerpt
(a key or two to add to a scenario) is merged into the scenario its
``doc-test: extends`` comment names and run the same way. The SPEC's
excerpts are classified below, since the contract carries no test comments;
an excerpt that cannot run is still read as YAML. Scenarios run for 0.3 s
(or their duration) with the Simulator ``cfem-sim run`` uses.
"""

import copy
import math
import pathlib
import re

from cfem_ros.core.fileio.yamlfile import load_yaml
import docblocks
import pytest
import yaml

ROOT = docblocks.ROOT
SPEC = ROOT / 'docs' / 'SPEC.md'

#: The SPEC's excerpts (by the number of their section): the section 1
#: scenario (or the example) they are added to, or why they cannot run as a scenario.
SPEC_EXCERPTS = {
    '1.': 'the format: every key at once',
    '5.': 'extends section 1',
    '7.': 'not run: an excerpt (release groups, compliance, wrenches tied to a release) '
          'naming joints (aft_hook) that it does not define',
    '8.': 'not run: an excerpt whose coefficient tables are left out (CX: ...)',
    '9.': 'not run: criteria of a sweep file, an excerpt with no scenario or sweep',
    '10.': 'extends config/store_clearance_aero.yaml, the example whose tables it leaves out',
    '11.': 'extends section 1 (braces on its store, a compound shape for its pylon)',
    '13.': 'not run: a fit file naming a scenario (two_hooks.yaml) and a flight log '
           '(flight_037.mcap) it does not come with',
    '14.': 'extends config/store_release_two_hooks_pullup.yaml, the two-hook store whose '
           'release condition it states',
}
#: Where the fit files a page shows are shipped (the page's commands run them).
FIT_FILES = ROOT / 'config' / 'fit'


def yaml_blocks():
    """Yield (block, document) for every YAML block of the SPEC, README and guide."""
    for page in [SPEC] + docblocks.pages():
        for block in docblocks.blocks(page):
            if block.lang == 'yaml':
                yield block


def _id(block):
    return block.where


def deep_merge(base, extra):
    """Return base with extra's mappings merged in and its other values replacing."""
    merged = copy.deepcopy(base)
    for key, value in extra.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = deep_merge(merged[key], value)
        elif isinstance(value, list) and isinstance(merged.get(key), list) and key == 'wrenches':
            merged[key] = merged[key] + value
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def spec_section_one():
    """Return the SPEC's section 1 scenario."""
    first = next(b for b in docblocks.blocks(SPEC) if b.lang == 'yaml')
    assert first.section.startswith('1.'), first.where
    return load_yaml(first.text)


def format_variants(document):
    """
    Return the SPEC's section 1 format as scenarios that run.

    The format shows every key at once, ``axis2`` among them, which its
    comment reserves for universal joints: it runs as written with each
    joint a universal joint, and with each joint of its own type without
    ``axis2``.
    """
    universal = copy.deepcopy(document)
    own_type = copy.deepcopy(document)
    for name, joint in document['joints'].items():
        if 'axis2' in joint:
            universal['joints'][name]['type'] = 'universal'
            del own_type['joints'][name]['axis2']
    return [own_type, universal]


def resolve(block, document):
    """Return the documents to run: the block's own, or merged into what it extends."""
    if block.path == SPEC:
        rule = next((v for k, v in SPEC_EXCERPTS.items() if block.section.startswith(k)), None)
        if rule is None:
            return [block.text]
        if rule.startswith('not run'):
            return []       # read as YAML above; nothing to run
        if rule.startswith('the format'):
            return format_variants(document)
        if rule.startswith('extends config/'):
            base = ROOT / rule.split()[1].rstrip(',')
            return [deep_merge(load_yaml(base.read_text(encoding='utf-8')), document)]
        return [deep_merge(variant, document) for variant in format_variants(spec_section_one())]
    if block.verb == 'skip':
        assert len(block.argument) > 10, f'{block.where}: a block not run says why'
        return []
    if block.verb == 'extends':
        base = ROOT / block.argument
        assert base.is_file(), f'{block.where}: extends {block.argument}, which does not exist'
        document = deep_merge(load_yaml(base.read_text(encoding='utf-8')), document)
        if 'scenario' in document:
            document['scenario'] = str((base.parent / document['scenario']).resolve())
        return [document]
    assert block.directive is None, f'{block.where}: unknown doc-test comment {block.directive!r}'
    return [block.text]


def base_scenario(block, path):
    """Return the absolute base scenario of a sweep written on a page."""
    candidates = [block.path.parent, ROOT / 'config' / 'sweeps']
    for folder in candidates:
        scenario = (folder / path).resolve()
        if scenario.is_file():
            return str(scenario)
    raise AssertionError(f"{block.where}: the sweep's scenario {path} is neither relative "
                         'to the page nor to config/sweeps/')


@pytest.mark.parametrize('block', list(yaml_blocks()), ids=_id)
def test_yaml_example_runs(block, tmp_path):
    document = load_yaml(block.text, block.where)
    assert isinstance(document, dict), f'{block.where}: not a YAML mapping'
    for k, variant in enumerate(resolve(block, document)):
        folder = tmp_path / str(k)
        folder.mkdir()
        # a block that runs as written is written as it is; merged ones are dumped
        text = variant if isinstance(variant, str) else yaml.safe_dump(variant, sort_keys=False)
        document = load_yaml(text)
        if block.verb == 'extends':
            # the merged file lies beside the files the extended one names (tables, meshes)
            for entry in (ROOT / block.argument).parent.iterdir():
                (folder / entry.name).symlink_to(entry)
        if 'measured' in document:
            _shipped_fit(block, document)
        elif 'vary' in document or 'scenario' in document:
            _run_sweep(block, text, folder)
        else:
            assert 'bodies' in document, (
                f'{block.where}: neither a scenario (bodies) nor a sweep (scenario, vary); '
                'mark an excerpt with doc-test: extends')
            _run_scenario(block, text, folder)


def _shipped_fit(block, document):
    """Check that a fit file a page shows is one shipped in config/fit (which its commands run)."""
    shipped = [path for path in sorted(FIT_FILES.glob('*.yaml'))
               if load_yaml(path.read_text(encoding='utf-8')) == document]
    assert shipped, (f'{block.where}: a fit file (measured) that is none of those in '
                     f'{FIT_FILES.relative_to(ROOT)}: show the shipped file as it is')


def _run_scenario(block, text, tmp_path):
    from cfem_ros import load_scenario, Simulator
    from cfem_ros.core.errors import ScenarioError

    path = tmp_path / 'cfem_doc_scenario.yaml'
    path.write_text(text, encoding='utf-8')
    try:
        model = load_scenario(str(path))
    except ScenarioError as err:
        raise AssertionError(f'{block.where}: refused: {err}') from None
    sim = Simulator(model)
    end = min(model.duration, 0.3)
    assert sim.advance_to(end) is not False and sim.status != 'failed', \
        f'{block.where}: the run failed: {sim.message}'
    assert sim.t == pytest.approx(end)


def _run_sweep(block, text, tmp_path):
    from cfem_ros.study import Sweep

    document = load_yaml(text)
    scenario = document['scenario']
    if not pathlib.Path(scenario).is_absolute():
        # the scenario's path is relative to where the page says the sweep file
        # lies; the copy written here names the same file absolutely
        line = re.compile(r'^scenario:\s*' + re.escape(scenario), re.M)
        assert line.search(text), f'{block.where}: no line "scenario: {scenario}"'
        text = line.sub(f'scenario: {base_scenario(block, scenario)}', text, count=1)
    path = tmp_path / 'cfem_doc_sweep.yaml'
    path.write_text(text, encoding='utf-8')
    sweep = Sweep.from_file(str(path), runs=1)
    assert sweep.total >= 1
    for k in range(min(sweep.total, 2)):
        row = sweep.run_one(k)
        assert row['status'] == 'ok', f'{block.where}: run {k} {row["status"]}: {row["message"]}'
        for key in document['vary']:
            assert key in row, f'{block.where}: no column for {key}'
        measured = [v for name, v in row.items()
                    if name.startswith(('clearance_', 'release_')) and isinstance(v, float)]
        assert measured and all(math.isfinite(v) for v in measured), (block.where, row)
