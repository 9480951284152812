"""``python -m grainmech ...``: the same command line as the ``grainmech`` script."""

import sys

from grainmech.cli import main

sys.exit(main())
