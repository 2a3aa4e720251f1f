"""``python -m marknav`` is the same as the ``marknav`` command."""

import sys

from marknav.cli import main

sys.exit(main())
