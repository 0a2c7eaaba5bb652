"""Large batches of exact queries shared with the second core: ``Partner(surface)`` forks a child that holds the
surface's libigl trees (inherited with the process, not built again) and answers one part of each batch it is
sent while this process answers the other.

Made for the distance field (``autorig.discretize.distance``), whose ~100k exact queries of a 60k-face mesh
are most of a rig's CPU time: libigl answers a batch on one core and holds the GIL, so a thread would not
overlap it. Each point's answer is computed alone, the same bits whichever process computes it and in any
batch (``SurfaceQuery._squared_distance``), so the field is the same with or without the partner.

As with ``autorig.weights.ahead`` (whose ``ENABLED`` switch it follows: ``autorig batch`` turns it off in its
workers, which keep every core busy already), only on Linux with two CPUs or more, and only while the machine
has a core to spare (``_idle_core``): with the cores busy with other work the child only waits for one, and
this process for the child (60k-face armadillo, two other processes running on 2 cores: the field's wall time
0.79 s alone, 0.85 s shared). A partner that could not be started, or a child that died, leaves the whole
batch to this process. Used as ``with surface.sharing():``
(``SurfaceQuery.sharing``), which stops the child at the block's end; a partner dropped unclosed stops it
when collected.
"""
from __future__ import annotations

import os
import signal
import sys
import warnings
import weakref

import numpy as np

PARTNER_MIN = 2048    # points: a smaller batch is answered here alone (the round trip is not worth it)
_QUIT, _DISTANCE, _WINDING = 0, 1, 2


IDLE_MARGIN = 0.25   # CPUs: the partner starts while the load average stays this much below the CPU count


def _idle_core() -> bool:
    """Whether a second core is likely free: two CPUs or more, and the 1-minute load average (which counts this
    process itself) under their number by ``IDLE_MARGIN``."""
    cpus = len(os.sched_getaffinity(0))
    return cpus >= 2 and os.getloadavg()[0] < cpus - IDLE_MARGIN


class Partner:
    """A forked child answering ``SurfaceQuery``'s raw queries (see the module)."""

    def __init__(self, surface):
        from ..weights import ahead
        self._pid = None
        self._surface = surface
        if not (ahead.ENABLED and sys.platform.startswith("linux") and _idle_core()):
            return
        ask_read, ask_write = os.pipe()
        answer_read, answer_write = os.pipe()
        try:
            with warnings.catch_warnings():
                # As in ``autorig.weights.ahead``: the child runs only libigl and numpy on its own arrays and
                # leaves with os._exit, never touching a lock another thread might have held at the fork.
                warnings.simplefilter("ignore", DeprecationWarning)
                pid = os.fork()
        except OSError:       # no process to be had (a limit on processes or memory): all answered here
            for fd in (ask_read, ask_write, answer_read, answer_write):
                os.close(fd)
            return
        if pid == 0:   # the child: answer until told to stop (or the parent is gone), then leave at once
            code = 1
            try:
                os.close(ask_write)
                os.close(answer_read)
                _serve(surface, ask_read, answer_write)
                code = 0
            finally:
                os._exit(code)
        os.close(ask_read)
        os.close(answer_write)
        self._pid, self._ask, self._answer = pid, ask_write, answer_read
        self._finalizer = weakref.finalize(self, _stop, pid, ask_write, answer_read)

    @property
    def alive(self) -> bool:
        return self._pid is not None

    def send(self, kind: int, points: np.ndarray) -> bool:
        """Ask the child for ``kind``'s answer at points [N, 3] (float64, C order); False if it is gone."""
        if self._pid is None:
            return False
        try:
            _write(self._ask, np.array([kind, len(points)], dtype=np.int64).tobytes())
            _write(self._ask, points.tobytes())
            return True
        except OSError:
            self.close()
            return False

    def receive(self, kind: int, count: int):
        """The child's answer to the last ``send`` of ``count`` points: (squared distances [N], triangles [N],
        nearest points [N, 3]) for distances, winding numbers [N] for winding; None if the child is gone."""
        width = 5 if kind == _DISTANCE else 1      # float64 / int64 values per point
        buffer = bytearray(8 * width * count)
        try:
            if not _read_into(self._answer, buffer):
                self.close()
                return None
        except OSError:
            self.close()
            return None
        if kind == _WINDING:
            return np.frombuffer(buffer, dtype=np.float64)
        sq = np.frombuffer(buffer, dtype=np.float64, count=count)
        face = np.frombuffer(buffer, dtype=np.int64, count=count, offset=8 * count)
        nearest = np.frombuffer(buffer, dtype=np.float64, count=3 * count, offset=16 * count).reshape(count, 3)
        return sq, face, nearest

    def close(self) -> None:
        """Stop the child and wait for it."""
        if self._pid is not None:
            self._finalizer()
            self._pid = None

    def __enter__(self):
        """Answer the surface's large batches while the block runs (``SurfaceQuery.sharing``)."""
        self._surface.partner = self
        return self

    def __exit__(self, *exc):
        self._surface.partner = None
        self.close()


def _serve(surface, ask: int, answer: int) -> None:
    """The child's loop: read a request (kind, count, points), answer it, until asked to quit or the pipe ends."""
    header = bytearray(16)
    while _read_into(ask, header):
        kind, count = (int(x) for x in np.frombuffer(header, dtype=np.int64))
        if kind == _QUIT:
            return
        points = bytearray(24 * count)
        if not _read_into(ask, points):
            return
        points = np.frombuffer(points, dtype=np.float64).reshape(count, 3)
        if kind == _DISTANCE:
            sq, face, nearest = surface.raw_squared_distance(points)
            out = [np.ascontiguousarray(sq, dtype=np.float64), np.ascontiguousarray(face, dtype=np.int64),
                   np.ascontiguousarray(nearest, dtype=np.float64)]
        else:
            out = [np.ascontiguousarray(surface.raw_winding(points), dtype=np.float64)]
        for part in out:
            _write(answer, part.tobytes())


def _write(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while len(view):
        view = view[os.write(fd, view):]


def _read_into(fd: int, buffer: bytearray) -> bool:
    """Fill ``buffer`` from ``fd``; False when the pipe ends first."""
    view = memoryview(buffer)
    while len(view):
        got = os.readv(fd, [view])
        if got == 0:
            return False
        view = view[got:]
    return True


def _stop(pid: int, ask: int, answer: int) -> None:
    """Tell the child to quit, close the pipes and wait for it (killed if it does not read the request)."""
    try:
        _write(ask, np.array([_QUIT, 0], dtype=np.int64).tobytes())
    except OSError:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    for fd in (ask, answer):
        try:
            os.close(fd)
        except OSError:
            pass
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:
        pass
