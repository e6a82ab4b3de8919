"""Benchmarks against the peers named in the issues (``make bench``)."""
