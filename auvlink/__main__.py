"""``python -m auvlink`` runs the command line."""

import sys

from auvlink.cli import main

sys.exit(main())
