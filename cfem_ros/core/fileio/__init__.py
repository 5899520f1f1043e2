# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
Reading the project's files: text files and YAML documents within fixed bounds.

Modules: ``textfile`` (``read_text``: a regular UTF-8 file of bounded size,
never blocking; ``file_kind``; ``display``), ``yamlfile`` (``load_yaml``: one
YAML document, safe, bounded in depth and alias expansion) and ``messages``
(``clip``, ``show``: values as error messages show them).
"""
