"""``python -m kanedyn.cli``: the ``kanedyn`` command."""

import sys

from ._main import main

sys.exit(main())
