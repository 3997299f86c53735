import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

# `make test` adds up one "N passed, N failed" line per step (tests/all.sh).
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests"))
from pytest_counts import pytest_runtest_logreport, pytest_terminal_summary  # noqa: E402,F401


def pytest_unconfigure(config):
    # bpy can hang at interpreter exit: leave at once with pytest's status.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(config._lensray_status if hasattr(config, "_lensray_status") else 0)


def pytest_sessionfinish(session, exitstatus):
    session.config._lensray_status = int(exitstatus)
