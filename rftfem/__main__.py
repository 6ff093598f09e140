"""``python -m rftfem`` is the ``rftfem`` command."""

import sys

from rftfem.cli import main

sys.exit(main())
