# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The node's recording (parameter ``record``, SPEC section 4): opened at start, finished at the end.

A write that fails (a full disk, a file size limit) ends the run: the
recorder keeps what is complete (``Recorder.abandon``) and one error line
says where the run got to and what the file holds.
"""

import os
from typing import Optional

from cfem_ros.core.errors import CfemError
from cfem_ros.recording.container import Recorder
from cfem_ros.recording.recorder import run_metadata, StateRecorder
from cfem_ros.ros.parameters import StartupError


class NodeRecording:
    """
    A node's recording of its run: the file's writer and the sampled state's.

    Raises StartupError if the file exists without overwrite, or cannot be made.
    """

    def __init__(self, node, sim, path: str, overwrite: bool):
        if os.path.lexists(path) and not overwrite:
            raise StartupError(f'parameter record: {path}: already exists; pass '
                               '-p overwrite:=true to replace it')
        try:
            self.recorder = Recorder(path, overwrite=overwrite)
        except CfemError as err:
            message = str(err).replace('--overwrite', '-p overwrite:=true')
            raise StartupError(f'parameter record: {message}') from None
        self.state = StateRecorder(self.recorder, sim, namespace=node.get_namespace())
        self.node, self.sim = node, sim

    def begin(self, start_ns: int, scenario_path: str, rate_hz: float, **metadata):
        """Stamp the samples from start_ns on and write the run's metadata."""
        self.state.start_ns = start_ns
        self.recorder.add_metadata(run_metadata(
            self.sim.model, scenario_path, rate_hz, start_ns,
            node=self.node.get_fully_qualified_name(), **metadata))

    def finish(self):
        """Finish the file (summary, indexes) and log how many messages it holds."""
        self.recorder.finish()
        self.node.get_logger().info(f'recording {self.recorder.path}: '
                                    f'{self.recorder.message_count} messages')

    def failed(self, err, start_ns: Optional[int]):
        """
        Keep what is complete after a failed write, and log one error line.

        err: the OSError of the write, or the ``OutputError`` the recorder
        gave for it.
        """
        if isinstance(err, OSError):
            err = self.recorder.abandon(err)
        kept = ''
        if err.kept_until_ns is not None and start_ns is not None:
            kept = (f'; the file ends at simulated t = '
                    f'{(err.kept_until_ns - start_ns) / 1e9:.9g} s')
        self.node.get_logger().error(
            f'recording failed at simulated t = {self.sim.t:.9g} s ({self.state.samples} '
            f'samples, {self.recorder.message_count} messages written): {err}{kept}; '
            'the run ends')
