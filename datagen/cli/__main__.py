"""``python -m datagen.cli``: the command line, as the ``datagen`` script runs it."""

import sys

from datagen.cli import main

sys.exit(main())
