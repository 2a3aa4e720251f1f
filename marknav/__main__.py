"""``python -m marknav`` is the same as the ``marknav`` command."""

from marknav.cli.main import entry

entry()
