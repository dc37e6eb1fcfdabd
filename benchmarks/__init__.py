"""Benchmarks: each module is runnable (``python -m benchmarks.NAME --json``) and prints
one JSON object as its last line."""
