"""weldseam: from a 3D scan of a grooved workpiece to an ordered 6-DOF welding path."""

__version__ = "0.1.0"
