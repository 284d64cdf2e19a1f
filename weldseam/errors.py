"""User-facing failures, one type per kind; `cli.py` maps each to an exit code."""


class WeldseamError(Exception):
    """Base of every failure weldseam reports to a user as one line."""


class InputError(WeldseamError):
    """Missing, unreadable or invalid input (scan, intrinsics, pose, config, option)."""


class NoSeamError(WeldseamError):
    """The scan was read and processed but no weld seam was found in it; `candidates` are what
    was considered, each with the reason it was rejected (pipeline.candidates.Candidate)."""

    def __init__(self, message: str, candidates: tuple = ()):
        super().__init__(message)
        self.candidates = candidates


class StageError(WeldseamError):
    """A pipeline stage could not do its job on this data; `stage` names it."""

    def __init__(self, stage: str, message: str):
        super().__init__(f"{stage}: {message}")
        self.stage = stage


class UnreachableError(WeldseamError):
    """A pose of the path cannot be reached by the robot (refused before any motion)."""


class RobotFault(WeldseamError):
    """The controller reported a fault or the connection broke (the robot is stopped)."""


class RobotConnectionError(WeldseamError):
    """The robot controller could not be reached or would not start a session (nothing moved)."""
