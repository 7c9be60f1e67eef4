"""``python -m widesky``: the ``widesky`` command line."""

import sys

from widesky.cli import main

sys.exit(main())
