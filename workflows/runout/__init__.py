"""Runout after failure: when a flow is at rest (:mod:`rest`) and what it did (:mod:`metrics`)."""
