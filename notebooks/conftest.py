"""The notebooks run under nbmake at the test settings (notebooks/README.md) unless
MILLSCOPE_NOTEBOOK_SCALE is already set."""

import os

os.environ.setdefault("MILLSCOPE_NOTEBOOK_SCALE", "test")
