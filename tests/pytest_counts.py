"""The pytest hooks that end a suite with the line `make test` adds up
(tests/all.sh): "N passed, N failed".  A conftest imports both hooks."""

_counts = {"passed": 0, "failed": 0}


def pytest_runtest_logreport(report):
    if report.when == "call" and report.passed:
        _counts["passed"] += 1
    elif report.failed:
        _counts["failed"] += 1
    elif report.skipped:
        # A skip is not a pass: the suites have none on purpose.
        _counts["failed"] += 1


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    terminalreporter.write_line(f"{_counts['passed']} passed, {_counts['failed']} failed")
