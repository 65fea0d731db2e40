"""How long work tells what it is doing: one set of hooks, every one optional.

A study calls :class:`Progress` from the places that know (the stage runner, the FOS engine, the
study types); the command line implements it with progress bars, the tests collect its messages,
and everything else passes the default, which does nothing.  No hook may change the work.
"""

from __future__ import annotations


class Progress:
    """The hooks of a running study; the base does nothing."""

    def stage(self, case: str, name: str, kind: str, fraction: float) -> None:
        """Stage ``name`` (of ``kind``) of case ``case`` ("" for a single study) is ``fraction`` done (0 to 1)."""

    def runs(self, done: int, planned: int) -> None:
        """SRF runs done and planned so far (all cases)."""

    def cases(self, done: int, total: int) -> None:
        """Cases concluded of all (a sweep)."""

    def case_started(self, index: int, total: int, case_id: str) -> None:
        """A case whose stages run in this process starts (a sweep of a stage study)."""

    def tally(self, text: str) -> None:
        """A running summary of the cases concluded so far (a probabilistic study: failed, pf)."""

    def message(self, text: str) -> None:
        """One line of news: reuse, skips, warnings (a warning starts with or contains ``warning``)."""


class Messages(Progress):
    """Progress that keeps the messages (``lines``) and ignores the rest."""

    def __init__(self):
        self.lines: list[str] = []

    def message(self, text: str) -> None:
        self.lines.append(text)


class CaseProgress(Progress):
    """Another Progress with a sub-study's messages and tallies prefixed with its case (the cases
    of a sweep of refinement or probabilistic studies); the rest dropped."""

    def __init__(self, progress: Progress, case_id: str):
        self.progress, self.case_id = progress, case_id

    def message(self, text: str) -> None:
        self.progress.message(f"case {self.case_id.replace('__', ', ')}: {text}")

    def tally(self, text: str) -> None:
        self.progress.tally(f"{self.case_id.replace('__', ', ')}: {text}")


class OnlyWarnings(Progress):
    """Another Progress with the messages that are no warning left out (a sweep's cases)."""

    def __init__(self, inner: Progress):
        self.inner = inner

    def stage(self, case, name, kind, fraction):
        self.inner.stage(case, name, kind, fraction)

    def runs(self, done, planned):
        self.inner.runs(done, planned)

    def cases(self, done, total):
        self.inner.cases(done, total)

    def case_started(self, index, total, case_id):
        self.inner.case_started(index, total, case_id)

    def tally(self, text):
        self.inner.tally(text)

    def message(self, text):
        if "warning" in text:
            self.inner.message(text)
