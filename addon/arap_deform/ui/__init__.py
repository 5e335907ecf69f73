# SPDX-License-Identifier: GPL-3.0-or-later
"""The sidebar panels, the viewport's status lines and the modal operators' timers."""
