"""Ctrl-C reaches the suite even when the shell that started it ignored SIGINT (tests/conftest.py).

The suite's Ctrl-C tests (streams, ensembles, resume) press Ctrl-C with ``os.kill(pid, SIGINT)``.
A suite started in the background by a shell without job control inherits SIGINT ignored; without
``conftest.pytest_configure`` putting Python's handler back, those tests fail ("DID NOT RAISE") or
wait for ever for a stop request that never comes.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parent


def test_ctrl_c_reaches_the_tests():
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with pytest.raises(KeyboardInterrupt):
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(10_000_000):     # the handler runs at the interpreter's next check, long before this ends
            pass


def test_a_suite_started_with_sigint_ignored_still_gets_ctrl_c():
    def ignore_sigint() -> None:        # what `cmd &` in a script without job control does to cmd
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    out = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:xdist",
         str(TESTS / "test_signals.py"), "-k", "reaches"],
        cwd=TESTS.parent, preexec_fn=ignore_sigint, capture_output=True, text=True, timeout=None,
    )
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    assert "1 passed" in out.stdout
