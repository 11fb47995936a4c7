"""``python -m millscope``: see :mod:`millscope.cli`."""

import sys

from .app.cli import main

sys.exit(main())
