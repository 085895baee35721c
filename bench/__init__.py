"""Benchmarks: measured figures printed beside their targets (`make bench`)."""
