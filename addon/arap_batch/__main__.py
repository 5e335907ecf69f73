# SPDX-License-Identifier: GPL-3.0-or-later
"""`python3 -m arap_batch`: the same as the arap-batch script."""

import sys

from .cli import main

sys.exit(main())
