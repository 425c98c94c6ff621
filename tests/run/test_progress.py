"""Progress a person can read: log lines always, a tqdm bar only in a terminal."""

from __future__ import annotations

import io
import logging

import numpy as np
import pytest

from tmopt.evaluation.archive import ArchiveData
from tmopt.run import progress
from tmopt.run.progress import ProgressReporter


def _data() -> ArchiveData:
    data = ArchiveData.empty(2, 2, 1)
    data.append(ArchiveData(X=np.zeros((3, 2)), F=np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]),
                            G=np.array([[-1.0], [-1.0], [1.0]]), failed=np.zeros(3, bool),
                            reason=["", "", ""], seed=np.zeros(3, int), wall_time=np.zeros(3),
                            batch=np.zeros(3, int)))
    return data


def _handlers():
    console_text, file_text = io.StringIO(), io.StringIO()
    console = logging.StreamHandler(console_text)
    to_file = logging.FileHandler("/dev/null")
    to_file.stream = file_text  # a file handler that writes where the test can read
    return console, to_file, console_text, file_text


@pytest.fixture
def progress_logger(monkeypatch):
    """``tmopt.progress`` at INFO with the test's handlers.  ``setLevel``, not the
    attribute: it clears the loggers' ``isEnabledFor`` caches, and an earlier test in the
    same process (a run at the root's WARNING) may have cached INFO as off -- under
    ``make test``'s two processes the lines then went nowhere."""
    logger = logging.getLogger("tmopt.progress")
    old = logger.level
    console, to_file, console_text, file_text = _handlers()
    monkeypatch.setattr(logger, "handlers", [console, to_file])
    logger.setLevel(logging.INFO)
    yield console, console_text, file_text
    logger.setLevel(old)


def test_line_holds_budget_share_igd_best_and_stage():
    reporter = ProgressReporter(10, ["f1", "f2"], enabled=False,
                                front=np.array([[0.0, 1.0], [1.0, 0.0]]))
    text = reporter.line(2, _data(), {"stage": 1})
    assert text == ("gen    2 | evals 3/10 | feasible  66.7% | IGD 0 | best f1=0 f2=0 "
                    "| stage=1")


def test_no_terminal_no_bar_and_the_line_goes_to_every_handler(progress_logger):
    _, console_text, file_text = progress_logger
    reporter = ProgressReporter(10, ["f1", "f2"])  # pytest's stdout is not a terminal
    assert reporter.bar is None
    reporter.update(1, _data(), {})
    reporter.close()
    assert "evals 3/10" in console_text.getvalue() and "evals 3/10" in file_text.getvalue()


def test_in_a_terminal_the_bar_shows_and_the_log_file_still_gets_the_line(monkeypatch,
                                                                           progress_logger):
    console, console_text, file_text = progress_logger
    bar_text = io.StringIO()
    monkeypatch.setattr(progress.sys, "stdout", type("Tty", (io.StringIO,), {
        "isatty": lambda self: True})())
    monkeypatch.setattr(progress.sys, "stderr", type("Tty", (io.StringIO,), {
        "isatty": lambda self: True, "write": lambda self, s: bar_text.write(s)})())
    reporter = ProgressReporter(10, ["f1", "f2"])
    assert reporter.bar is not None
    reporter.update(1, _data(), {"stage": 2})
    reporter.close()
    assert "evals 3/10" in file_text.getvalue()  # tmopt.log
    assert console_text.getvalue() == ""  # the bar replaces the line on the console
    assert "3/10" in bar_text.getvalue() and "stage=2" in bar_text.getvalue()
    assert not console.filters  # the console is as it was after the run


def test_stiffness_runs_show_the_best_m_of_eq_29():
    reporter = ProgressReporter(10, ["convergence_time_TM1", "convergence_accuracy_TM1"],
                                enabled=False, m_weights=(1 / 60, 1e10))
    data = _data()
    data.F = np.array([[600.0, 5e-11], [120.0, 9e-11], [60.0, 1e-12]])  # row 3 infeasible
    # M = 600/60 + 0.5 = 10.5 and 120/60 + 0.9 = 2.9: the best feasible is 2.9
    assert "| best M 2.9 |" in reporter.line(1, data, {})
