"""`python -m transplanter.cli`: the command line."""

import sys

from transplanter.cli import main

sys.exit(main())
