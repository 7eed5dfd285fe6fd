"""Benchmarks: the seed's approach ported as a baseline, and the speed measurements recorded in BENCHMARKS.md.

Run them as commands (``python -m benchmarks.speed``); timings never live in unit tests.
"""
