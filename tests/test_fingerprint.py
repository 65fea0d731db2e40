"""Golden regression: the quickstart's summary and gravity state and the cantilever's time
series against the fingerprint stored in ``verification/fingerprint.json``.

Compared within a tolerance (samples to 1e-6 relative, verdicts and strings exactly) so that
a machine whose compiler fuses multiply-adds differently passes; ``python -m
verification.fingerprint --check`` compares bit for bit.  A change meant to move these numbers
stores a new fingerprint (``--update``) and says why in its commit."""

from __future__ import annotations

from pathlib import Path

from verification import fingerprint
from workflows.study import load_study
from workflows.study_types import run_study

REPO = Path(__file__).resolve().parents[1]


def test_quickstart_and_beam_match_the_stored_fingerprint(quickstart_run, tmp_path):
    _, out, _ = quickstart_run
    run_study(load_study(REPO / fingerprint.STUDIES["cantilever_beam"]), tmp_path)
    measured = {"quickstart": fingerprint.quickstart_prints(out), "cantilever_beam": fingerprint.beam_prints(tmp_path)}
    assert fingerprint.compare(measured, fingerprint.stored(), rtol=1e-6, atol=1e-12) == []
