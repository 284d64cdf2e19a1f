"""Synthetic test data: workpiece scenes with known seams (scenes.py, and the further joints
in joints.py, pipes.py, valley.py), supports and clutter (fixtures.py), camera placements
(cameras.py), a simulated D415 and a high-resolution sensor (sensor.py), one place that draws
a rendered case (catalog.py), and metrics that score weld paths against the truth."""
