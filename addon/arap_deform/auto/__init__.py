# SPDX-License-Identifier: GPL-3.0-or-later
"""Auto mode: poses that follow their handles (auto.py), bound off the main thread (background_bind.py)."""
