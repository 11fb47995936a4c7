"""``python -m millscope``: see :mod:`millscope.cli`."""

import sys

from .cli import main

sys.exit(main())
