"""A stop signal that lands where Python cannot pass its exception on is noted, not printed: a
destructor's (``sys.unraisablehook``) or a library's C code that prints the error itself
(``PyErr_Print``, through ``sys.excepthook``: seen under mpirun, from an import a signal
interrupted during start-up). The command then stops at its next check, in one line."""

import signal
import subprocess
import sys

from conftest import serial_only

SCRIPT = """
import sys
from rodfem.output import interrupts
interrupts.install()
with interrupts.command():
    sys.excepthook(interrupts.Interrupted, interrupts.Interrupted(10), None)
    class Unraisable:
        def __del__(self):
            raise interrupts.Interrupted(15)
    Unraisable()
    print("still running", flush=True)
    sys.excepthook(ValueError, ValueError("another error"), None)
sys.excepthook(interrupts.Interrupted, interrupts.Interrupted(2), None)
"""


@serial_only
def test_an_interrupt_printed_by_a_library_is_noted_not_printed():
    done = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "still running\n"
    # while the command runs, the stop signals' exceptions say nothing, any other error is
    # printed as Python prints it; after it, an Interrupted nobody caught is printed too
    assert "ValueError: another error" in done.stderr, done.stderr
    assert "Interrupted: interrupted by SIGINT" in done.stderr, done.stderr
    assert "SIGUSR1" not in done.stderr and "SIGTERM" not in done.stderr, done.stderr
    assert signal.SIGUSR1 == 10 and signal.SIGTERM == 15
