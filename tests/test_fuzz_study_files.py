"""Mutated study files never end in a traceback or a half-written result
(``verification.fuzz_study_files``): exit 0 with complete files, exit 2 with one line and
nothing written, or exit 1 with one line when a valid study drives the solver past its limits.
A fixed set of 150 mutants (derandomized) keeps the run time bounded (about 40 s);
``python -m verification.fuzz_study_files --examples 1500 --random`` explores new ones."""

from __future__ import annotations

from verification.fuzz_study_files import fuzz


def test_mutated_study_files_end_cleanly():
    counts = fuzz(max_examples=150)
    assert sum(counts.values()) == 150
    assert counts["exit 2"] > counts["exit 0"] > 0  # both valid and invalid mutants were tried
