"""``python -m station``: the ``station`` command line."""

import sys

from station.cli import main

sys.exit(main())
