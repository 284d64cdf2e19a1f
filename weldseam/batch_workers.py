"""How a batch runs its worker processes, and how a signal stops it.

Supervisors stop a batch with SIGINT (Ctrl-C, `timeout -s INT`), SIGTERM (systemd, docker,
`timeout`) or SIGHUP (a closed terminal), sent to the main process alone or to its whole
process group. Every case ends the same way: the main process takes the first signal
(`StopSignals`), the workers leave SIGINT and SIGHUP to it and exit on SIGTERM, the main
process stops them (SIGTERM, then SIGKILL after STOP_GRACE_S), and a worker also gets SIGTERM
from the kernel when the main process dies (Linux), so no process is ever left behind.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
# A worker stops at its next Python instruction; a long C call (a search tree query) delays it.
STOP_GRACE_S = 5.0
_PR_SET_PDEATHSIG = 1


class Interrupted(KeyboardInterrupt):
    """A stop signal reached the batch: `signum`; the exit status is 128 + signum (the shell's rule)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class StopSignals:
    """While open, the first of STOP_SIGNALS is recorded in `signum`, wakes `wake_fd` and, unless
    `deferred`, raises Interrupted where the main thread is; the later ones are ignored, so that
    the clean-up (stopping the workers, writing the summary) runs to its end."""

    def __init__(self):
        self.signum: int | None = None
        self.deferred = False
        self._previous: dict = {}
        self.wake_fd, self._wake_write = -1, -1
        self._pid = os.getpid()

    def __enter__(self) -> StopSignals:
        self._pid = os.getpid()
        self.wake_fd, self._wake_write = os.pipe()
        os.set_blocking(self._wake_write, False)
        self._previous = {signum: signal.signal(signum, self._caught) for signum in STOP_SIGNALS}
        return self

    def _caught(self, signum: int, frame) -> None:
        if os.getpid() != self._pid:  # a child forked by the pipeline that kept our handler: as if we were not here
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        if self.signum is not None:
            return
        self.signum = signum
        os.write(self._wake_write, b"!")
        if not self.deferred:
            raise Interrupted(signum)

    def raise_if_caught(self) -> None:
        """Interrupted if a stop signal came: its exception may have been swallowed where it
        was raised (Python only prints one raised in an at-fork hook or a finaliser)."""
        if self.signum is not None:
            raise Interrupted(self.signum)

    def __exit__(self, *exc) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        os.close(self.wake_fd)
        os.close(self._wake_write)


@dataclass(frozen=True)
class WorkerDied:
    """The result of an item whose worker process died on it (a crash, the out-of-memory killer)."""

    exitcode: int

    def __str__(self) -> str:
        if self.exitcode < 0:
            return f"the worker process was killed by {signal.Signals(-self.exitcode).name} on this scan"
        return f"the worker process crashed on this scan (exit code {self.exitcode})"


class _Worker:
    """One worker process, the pipe to it and the item it is working on."""

    def __init__(self, context, func: Callable):
        from multiprocessing import Pipe

        self.connection, theirs = Pipe()
        # Forked with the stop signals blocked: a signal in the gap before the worker sets its
        # own handlers waits for them instead of running the main process's handler in the worker.
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
        try:
            # daemon: a worker may not fork helpers of its own (pipeline/parallel.py), which
            # would outlive it when it is stopped; the batch uses every core with workers instead.
            self.process = context.Process(target=_serve, args=(func, theirs, os.getpid()), daemon=True)
            self.process.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
        theirs.close()  # so that its death reads as the end of the pipe here
        self.item = None

    def hand(self, item) -> None:
        self.item = item
        self.connection.send(item)

    def result(self):
        """The result of its item, or WorkerDied when the pipe ends (the process is gone)."""
        try:
            return self.connection.recv()
        except EOFError:
            self.process.join()
            self.connection.close()
            return WorkerDied(self.process.exitcode)

    def finish(self) -> None:
        """No more items: the worker returns."""
        self.connection.send(None)
        self.process.join()
        self.connection.close()


def run_in_processes(
    func: Callable, items: Iterable, processes: int, stop: StopSignals | None = None
) -> Iterator[tuple[object, object]]:
    """(item, func(item)) pairs in completion order, from `processes` forked worker processes,
    each holding one item at a time. An item whose worker dies gets WorkerDied in place of its
    result, and a new worker takes the remaining items. With `stop`, a stop signal raises
    Interrupted here (never while a result is half read); on any exit the workers are stopped."""
    import multiprocessing
    from multiprocessing.connection import wait

    context = multiprocessing.get_context("fork")
    pending = list(items)[::-1]
    workers: list[_Worker] = []
    if stop is not None:
        stop.deferred = True
    try:
        while pending and len(workers) < processes:
            workers.append(_Worker(context, func))
            workers[-1].hand(pending.pop())
        while workers:
            ready = wait([worker.connection for worker in workers] + ([stop.wake_fd] if stop else []))
            if stop is not None:
                stop.raise_if_caught()
            for worker in [worker for worker in workers if worker.connection in ready]:
                item, result = worker.item, worker.result()
                if isinstance(result, WorkerDied):
                    workers.remove(worker)
                    worker = _Worker(context, func) if pending else None
                    workers += [worker] if worker else []
                if worker is not None and pending:
                    worker.hand(pending.pop())
                elif worker is not None:
                    worker.finish()
                    workers.remove(worker)
                yield item, result
    finally:
        _stop(workers)
        if stop is not None:
            stop.deferred = False


def _stop(workers: list[_Worker]) -> None:
    """SIGTERM to every live worker, SIGKILL to those still alive STOP_GRACE_S later."""
    for worker in workers:
        worker.process.terminate()
    deadline = time.monotonic() + STOP_GRACE_S
    for worker in workers:
        worker.process.join(max(0.0, deadline - time.monotonic()))
    for worker in workers:
        if worker.process.is_alive():
            worker.process.kill()
            worker.process.join()
        worker.connection.close()


def _serve(func: Callable, connection, parent_pid: int) -> None:
    """A worker: func on each item received, its result sent back, until None or a closed pipe."""
    _die_with(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the main process decides, and stops us
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_cleanly)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
    try:
        while (item := connection.recv()) is not None:
            connection.send(func(item))
    except EOFError:
        pass


def _exit_cleanly(signum: int, frame) -> None:
    """SystemExit unwinds the job, so a file being written is removed (io/atomic.py), not left half done."""
    raise SystemExit(128 + signum)


def _die_with(parent_pid: int) -> None:
    """Ask Linux to send this process SIGTERM when the main process dies, even by SIGKILL."""
    import ctypes

    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # not Linux: the closed pipe stops the worker after its item
        pass
    if os.getppid() != parent_pid:  # it died before the request
        raise SystemExit(128 + signal.SIGTERM)
