"""``python -m rangemesh.cli`` runs the command line (as ``python -m rangemesh`` does)."""

import sys

from . import main

sys.exit(main())
