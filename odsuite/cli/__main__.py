"""``python -m odsuite.cli``: the command line."""

import sys

from odsuite.cli import main

sys.exit(main())
