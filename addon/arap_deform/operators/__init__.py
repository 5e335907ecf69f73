# SPDX-License-Identifier: GPL-3.0-or-later
"""The operators: set-up, Deform and the rest poses, Live, the bake; and what a .blend saved while Live or a
bake runs holds (saving.py)."""
