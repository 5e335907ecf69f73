# SPDX-License-Identifier: GPL-3.0-or-later
"""What the .blend keeps: the settings (properties.py, solver_settings.py) and the temporary files written
beside it (temp_files.py)."""
