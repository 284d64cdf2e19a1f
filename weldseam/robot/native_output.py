"""Keep what ur-rtde's C++ prints out of the user's terminal, so `send` says one thing, its own.

ur-rtde 1.6.5 writes to file descriptors 1 and 2 itself (std::cout, std::cerr), also from its
background threads at any moment ("Reconnecting...", "RTDEControlInterface Exception: End of
file"), so replacing Python's sys.stdout is not enough: for the session the descriptors point at
/dev/null and Python's streams keep writing to the terminal through copies of the originals.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def native_output_silenced() -> Iterator[None]:
    """For the duration: fds 1 and 2 go to /dev/null; sys.stdout and sys.stderr still reach the terminal."""
    originals = (sys.stdout, sys.stderr)
    for stream in originals:
        stream.flush()
    copies = [
        os.fdopen(os.dup(descriptor), "w", buffering=1, encoding=stream.encoding, errors=stream.errors)
        for descriptor, stream in zip((1, 2), originals)
    ]
    sink = os.open(os.devnull, os.O_WRONLY)
    for descriptor in (1, 2):
        os.dup2(sink, descriptor)
    os.close(sink)
    sys.stdout, sys.stderr = copies
    try:
        yield
    finally:
        for descriptor, copy in zip((1, 2), copies):
            copy.flush()
            os.dup2(copy.fileno(), descriptor)
        sys.stdout, sys.stderr = originals
        for copy in copies:
            copy.close()
