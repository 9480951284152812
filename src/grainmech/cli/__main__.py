"""``python -m grainmech.cli``: the ``grainmech`` command line."""

import sys

from grainmech.cli import main

sys.exit(main())
