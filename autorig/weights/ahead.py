"""Work started ahead on the second core: ``Ahead(fn, args)`` runs ``fn(*args)`` in a forked child process
while this one goes on, and ``.result_if(*args)`` returns its value.

Made for the skin weights: the surface the heat is solved on and its Laplacian (``autorig.weights.attach.heat_surface``)
depend only on the mesh, so they are made while the skeleton stages run (a 1M-face scan: ~1.4 s of quadric
decimation off the critical path; a 20k-face character with slivers: its intrinsic Delaunay Laplacian).
fast-simplification and libigl hold the GIL, so a thread would not overlap them.

The caller gets the same value whichever way it is made: off Linux (Windows has no fork; macOS's system
libraries are not safe to use in a forked child), with a single CPU, when the child fails, or with ``ENABLED``
off, ``result_if`` gives None and the caller computes it itself.
``autorig batch`` turns it off in its workers, whose pool already keeps every core busy. The child writes its
value down a pipe and ends; a handle dropped unread stops its child.
"""
from __future__ import annotations

import os
import pickle
import signal
import sys
import warnings
import weakref

ENABLED = True


def _spare_core() -> bool:
    return len(os.sched_getaffinity(0)) >= 2


class Ahead:
    """``fn(*args)`` begun in a forked child when ``wanted`` and that can run beside this process (see the
    module); ``fn`` must not return None."""

    def __init__(self, fn, args: tuple, wanted: bool = True):
        self._args = args
        self._child = None
        if not (wanted and ENABLED and sys.platform.startswith("linux") and _spare_core()):
            return
        read, write = os.pipe()
        with warnings.catch_warnings():
            # Python 3.12+ warns about fork() in a process with threads (numpy's BLAS starts some), for fear of a
            # lock another thread held at the fork. The child runs only numpy, libigl and fast-simplification on
            # its own arrays and leaves with os._exit, never touching such a lock.
            warnings.simplefilter("ignore", DeprecationWarning)
            pid = os.fork()
        if pid == 0:   # the child: compute, send, and leave without running the parent's exit handlers
            code = 1
            try:
                os.close(read)
                with os.fdopen(write, "wb") as pipe:
                    pickle.dump(fn(*args), pipe, protocol=pickle.HIGHEST_PROTOCOL)
                code = 0
            finally:
                os._exit(code)
        os.close(write)
        pipe = os.fdopen(read, "rb")
        self._child = pid
        self._pipe = pipe
        self._finalizer = weakref.finalize(self, _reap, pid, pipe, True)

    def result_if(self, *args):
        """The child's value if it was started with these very objects (``is``: a caller whose inputs were
        replaced since, a mesh turned to another frame, computes afresh), else None: None too when no child
        was started or it failed. The child is waited for (or stopped) either way."""
        if self._child is None:
            return None
        same = len(args) == len(self._args) and all(a is b for a, b in zip(args, self._args))
        value = None
        if same:
            try:
                value = pickle.load(self._pipe)
            except Exception:   # the child died (killed, out of memory): the caller does the work
                value = None
        self._finalizer.detach()
        _reap(self._child, self._pipe, value is None)
        self._child = None
        return value


def _reap(pid: int, pipe, stop: bool) -> None:
    """Close the pipe, stop the child if its value is not wanted (``stop``; a rig that failed before its skin
    weights should not wait for it), and wait for it."""
    pipe.close()
    if stop:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:
        pass
