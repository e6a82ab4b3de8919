"""Benchmarks against the standard peers (``make bench``)."""
