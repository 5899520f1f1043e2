# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Recordings: MCAP files written as a run goes, read back and analysed.

Modules: ``msgdefs`` (the ROS 2 message definitions written as schemas),
``chunks`` (the MCAP chunk writer), ``recorder`` (``Recorder``,
``StateRecorder``: a run's messages into a file), ``replay`` (a log's
inputs, to replay), ``offline`` (a whole run to a file), ``analysis``
(``open_run``, ``compare_runs``), ``errors`` (``RecordingError``).

This layer imports the core, never rclpy.
"""
