"""Column collapses: the metrics of a final deposit and the experiment they are compared with."""
