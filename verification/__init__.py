"""Verification tooling shared by the tests and the benchmarks: reference scenes, analytic and
published references, probes of single kernels, the stability stress suite and the golden
fingerprint.  Not installed with the package: run from a source checkout
(``python -m verification.stress_suite``, ``python -m verification.fingerprint --check``)."""
