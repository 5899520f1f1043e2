# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Separation studies: sweeps of many runs and their metrics (SPEC section 6).

``Sweep.from_file(path).run(client, outdir)`` returns a pandas DataFrame,
one row per run; ``summarize`` computes the same metrics from recordings.
Needs the ``study`` extra (dask[distributed], pandas, pyarrow) to run.
"""

from cfem_ros.study.errors import SweepError
from cfem_ros.study.spec import load_sweep, SweepSpec
from cfem_ros.study.summarize import summarize
from cfem_ros.study.sweep import Sweep

__all__ = ['load_sweep', 'summarize', 'Sweep', 'SweepError', 'SweepSpec']
