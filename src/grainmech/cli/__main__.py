import sys

from grainmech.cli import main

sys.exit(main())
