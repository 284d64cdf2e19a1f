"""Synthetic test data: workpiece scenes with known seams, a simulated D415, and metrics
that score weld paths against the truth."""
