"""``python -m marknav`` and the ``marknav`` console script: the first code marknav runs.

The signal policy (:mod:`marknav.core.signals`, which imports nothing heavy) is installed before
the command line and its sub-commands are imported, so a Ctrl-C, SIGTERM or SIGHUP in the first
fraction of a second exits 130 like any other, without a traceback; the process ends through
:func:`marknav.core.signals.exit_process`, so one after the command returned does too.
"""

from __future__ import annotations

import os
import signal
import sys


def entry() -> None:
    """Run the command line (``sys.argv``) and end the process with its exit code."""
    try:
        from marknav.core import signals

        signals.install()
        # Importing the commands loads the heavy libraries (≈ 1 s): a signal meanwhile is
        # raised once they are in. Raised inside an extension's import it can come out as that
        # library's own error (pydantic-core turns it into a PanicException).
        with signals.deferred():
            from marknav.cli.main import main
    except KeyboardInterrupt:  # before the command line was ready: nothing was started
        policy = sys.modules.get("marknav.core.signals")
        for s in getattr(policy, "ENDING_SIGNALS", (signal.SIGINT, signal.SIGTERM)):
            signal.signal(s, signal.SIG_IGN)
        os.write(2, b"marknav: interrupted\n")
        os._exit(130)
    signals.exit_process(main(exiting=True))


if __name__ == "__main__":
    entry()
