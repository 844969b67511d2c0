"""``python -m predgait`` runs the command line."""

import sys

from predgait.cli import main

sys.exit(main())
