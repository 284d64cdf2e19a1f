"""OpenCV's own messages: its C++ code writes them straight to file descriptor 2, past sys.stderr."""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def opencv_messages() -> Iterator[list[str]]:
    """While open, whatever is written to file descriptor 2 goes to a temporary file instead of the terminal;
    on leaving, its lines are in the list yielded (for the caller to judge, e.g. "... failed!")."""
    sys.stderr.flush()
    messages: list[str] = []
    saved = os.dup(2)
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield messages
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            messages += sink.read().decode(errors="replace").splitlines()
