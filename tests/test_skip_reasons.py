"""The test run says once which data folder is missing and what that leaves untested."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from tests import conftest


class _Reporter:
    """The part of pytest's terminal reporter the summary hook uses."""

    def __init__(self, skipped: list[Any]) -> None:
        self.stats = {"skipped": skipped}
        self.lines: list[str] = []

    def section(self, title: str, sep: str = "=") -> None:
        self.lines.append(f"== {title} ==")

    def write_line(self, line: str) -> None:
        self.lines.append(line)


def _skip(reason: str) -> Any:
    return SimpleNamespace(longrepr=("file.py", 1, f"Skipped: {reason}"))


def test_summary_names_the_missing_folder_once_with_its_count(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    absent, present = tmp_path / "shared" / "tracks", tmp_path / "shared" / "logs"
    present.mkdir(parents=True)
    monkeypatch.setattr(conftest, "SHARED_DATA", {absent: "real routes", present: "real traces"})
    reporter = _Reporter(
        [_skip(f"{absent}/a.npy is absent: ..."), _skip(f"{absent}/b.npy is absent: ..."),
         _skip("needs openvino")]  # fmt: skip
    )
    conftest.pytest_terminal_summary(reporter, 0, None)  # type: ignore[arg-type]
    text = "\n".join(reporter.lines)
    assert text.count(str(absent)) == 1, text
    assert f"{absent} is absent: 2 tests skipped, leaving untested real routes." in text
    assert "1 skipped: needs openvino" in text
    assert str(present) not in text
    header = conftest.pytest_report_header(None)  # type: ignore[arg-type]
    assert header == [f"{absent} is absent; the tests of real routes will skip."]


def test_summary_is_silent_when_nothing_skipped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(conftest, "SHARED_DATA", {tmp_path: "real routes"})
    reporter = _Reporter([])
    conftest.pytest_terminal_summary(reporter, 0, None)  # type: ignore[arg-type]
    assert reporter.lines == []
