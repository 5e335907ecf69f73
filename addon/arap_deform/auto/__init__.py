# SPDX-License-Identifier: GPL-3.0-or-later
"""Auto mode: poses that follow their handles (auto.py), and the played frames' final poses (final_poses.py)."""
