# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Reading a study folder's files back: one clear error for a missing or damaged one.

A sweep folder holds ``sweep.json`` (what was run), ``parts/*.parquet`` (the
rows of each finished task) and ``results.parquet`` (the table made from the
parts). A file cut short (a full disk, a copy stopped half-way) or edited by
hand is named with what is wrong and what to do, never a reader's traceback.
"""

from __future__ import annotations

import json
import os

from cfem_ros.core.errors import CfemError

MANIFEST = 'sweep.json'
RESULTS = 'results.parquet'
#: What a folder needs to be reported on or rerun.
FOLDER = 'a sweep folder (sweep.json, results.parquet: the -o folder of cfem-sim sweep)'


class FolderError(CfemError):
    """A study folder, or one of its files, that cannot be read."""


def _reason(err: BaseException) -> str:
    if isinstance(err, OSError) and err.strerror:
        return err.strerror
    return ' '.join(f'{type(err).__name__}: {err}'.split())[:160]


def read_manifest(outdir: str) -> dict:
    """Return a folder's ``sweep.json``; FolderError if it is missing or damaged."""
    path = os.path.join(outdir, MANIFEST)
    try:
        with open(path, encoding='utf-8') as stream:
            held = json.load(stream)
    except FileNotFoundError:
        raise FolderError(f'{outdir}: has no {MANIFEST}; expected {FOLDER}') from None
    except OSError as err:
        raise FolderError(f'{path}: cannot be read ({_reason(err)}); expected {FOLDER}') \
            from None
    except ValueError as err:   # not JSON, not UTF-8
        raise FolderError(f'{path}: damaged ({_reason(err)}); expected the {MANIFEST} a '
                          'sweep wrote: run the sweep again into a new folder') from None
    if not isinstance(held, dict) or not isinstance(held.get('digest'), str):
        raise FolderError(f'{path}: damaged (not the mapping a sweep writes, with its '
                          f'digest); expected the {MANIFEST} a sweep wrote: run the sweep '
                          'again into a new folder')
    return held


def read_table(path: str, what: str = 'table'):
    """Return a Parquet file of a folder as a DataFrame; FolderError if it cannot be read."""
    import pandas as pd
    try:
        return pd.read_parquet(path)
    except FileNotFoundError:
        raise FolderError(f'{os.path.dirname(path)}: has no {os.path.basename(path)}; '
                          f'expected {FOLDER}') from None
    except Exception as err:  # noqa: B902 - any reader error is the file's damage
        todo = ('remove it and run the same sweep command again: its runs are done again'
                if what == 'part' else 'run the same sweep command again: it writes the '
                'table again from the parts')
        raise FolderError(f'{path}: damaged ({_reason(err)}); expected the {what} a sweep '
                          f'wrote: {todo}') from None


def check_folder(outdir: str) -> dict:
    """Check that outdir is a readable sweep folder before it is read; return its manifest."""
    if not os.path.isdir(outdir):
        raise FolderError(f'{outdir}: is not a folder; expected {FOLDER}')
    manifest = read_manifest(outdir)
    read_table(os.path.join(outdir, RESULTS))
    return manifest
