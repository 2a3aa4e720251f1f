"""``python -m marknav`` and the ``marknav`` console script: the first code marknav runs.

The signal policy (:mod:`marknav.signals`, which imports nothing heavy) is installed before the
command line and its sub-commands are imported, so a Ctrl-C or SIGTERM in the first fraction of a
second exits 130 like any other, without a traceback; the process ends through
:func:`marknav.signals.exit_process`, so one after the command returned does too.
"""

from __future__ import annotations

import os
import signal


def entry() -> None:
    """Run the command line (``sys.argv``) and end the process with its exit code."""
    try:
        from marknav import signals

        signals.install()
        from marknav.cli import main
    except KeyboardInterrupt:  # before the command line was ready: nothing was started
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN)
        os.write(2, b"marknav: interrupted\n")
        os._exit(130)
    signals.exit_process(main(exiting=True))


if __name__ == "__main__":
    entry()
