"""The batch's workers: one asset rigged in a scratch folder from the bytes sent to it (``rig_one``), and the
local process pool that runs them (``run_locally``; ``autorig.batch.cluster`` runs them on Dask instead)."""
from __future__ import annotations

import contextlib
import os
import tempfile
import time
from concurrent.futures import FIRST_COMPLETED, wait
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Iterator

from ..errors import AutorigError, SkeletonError, missing_package
from ..quiet import quiet_libraries

if TYPE_CHECKING:
    from .plan import Plan

# Each asset's budget in a local worker: past ASSET_SECONDS of rigging it fails ("took longer than"), and a
# worker's address space is capped at ASSET_MEMORY, so that one hostile asset cannot hang the batch or exhaust
# the machine (the readers' own checks catch the known ones long before: autorig.limits).
ASSET_SECONDS = 600
ASSET_MEMORY = 8 << 30
SCRATCH_PREFIX = "autorig-batch-"

# libigl's own thread pool (its AABB distance queries and winding numbers) reads IGL_NUM_THREADS: without it each
# worker of "-j 2" would start two threads and the pair would fight over the two cores.
_THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "IGL_NUM_THREADS")


@dataclass(frozen=True)
class Job:
    """What a worker needs: the input's files by relative name (the mesh first), the template or the parsed
    skeleton (workers read no files but the ones sent), and the options."""
    name: str
    files: dict[str, bytes]
    template: object
    skeleton: object
    options: object
    fmt: str
    names: str = "template"
    thumbnails: bool = False
    timeout: float | None = ASSET_SECONDS


def rig_one(job: Job) -> dict:
    """Rig one asset in a worker (a local process or a Dask worker): write its files to a scratch folder,
    rig, write the output there and return the output's bytes. Never raises for a problem with the asset."""
    from ..weights import ahead
    from ..exchange import write_rig
    from ..pipeline import rig, skin

    ahead.ENABLED = False   # the pool keeps every core busy already: no helper processes of its own
    start = time.perf_counter()
    # The process id in the name: a batch killed while rigging leaves it behind, and the next one removes the
    # scratch folders of processes no longer running (remove_stale_scratch).
    with tempfile.TemporaryDirectory(prefix=f"{SCRATCH_PREFIX}{os.getpid()}-") as scratch, quiet_libraries(), \
            _time_limit(job.timeout):
        source = Path(scratch, "in")
        mesh = source / next(iter(job.files))
        try:
            for name, data in job.files.items():
                (source / name).parent.mkdir(parents=True, exist_ok=True)
                (source / name).write_bytes(data)
            if job.skeleton is None:
                options = job.options
                if getattr(options, "markers", None) is not None:   # its markers file, sent beside the mesh
                    from dataclasses import replace
                    options = replace(options, markers=str(mesh.with_name(Path(options.markers).name)))
                result = rig(str(mesh), job.template, options)
            else:
                if job.fmt == "pinocchio":
                    # What write_pinocchio would refuse after the work; the command line says so up front.
                    from ..exchange.pinocchio import unfit_skeleton
                    problem = unfit_skeleton(job.skeleton.parents)
                    if problem:
                        raise SkeletonError(f"{job.name}: {problem}")
                result = skin(str(mesh), job.skeleton, job.options)
            from ..naming import rename_joints
            result = rename_joints(result, job.names)
            timings = dict(result.timings)
            result.timings = {}  # they differ on every run, and the outputs must not
            written = time.perf_counter()
            out = write_rig(result, Path(scratch, "rig"), job.fmt)
            timings["write"] = time.perf_counter() - written
            data = {p.name: p.read_bytes() for p in sorted(out.iterdir())} if out.is_dir() else out.read_bytes()
            pictures = {}
            if job.thumbnails:
                drawn = time.perf_counter()
                pictures = _thumbnails_of(result)
                timings["thumbnails"] = time.perf_counter() - drawn
            confidence = result.info.get("confidence")
            return {"status": "ok", "remember": True, "data": data, "timings": timings, "thumbnails": pictures,
                    "confidence": None if confidence is None else float(confidence),
                    "confidence_parts": dict(result.info.get("confidence_parts") or {}),
                    "confidence_reasons": list(result.info.get("confidence_reasons") or []),
                    "axes": ([result.info["up"], result.info["front"]]
                             if job.skeleton is None and "up" in result.info else None),
                    "dropped": list(result.info.get("dropped", [])),
                    "hands": dict(result.info.get("hands") or {}),
                    "rest_pose": result.info.get("rest_pose"), "arm_angle": result.info.get("arm_angle"),
                    "seconds": time.perf_counter() - start}
        except AutorigError as e:
            error, error_type, remember = str(e), type(e).__name__, True
        except _TimedOut:
            error, error_type, remember = (f"could not rig: took longer than {job.timeout:g} s (the batch's limit "
                                           f"per asset)"), "RigFailedError", False
        except MemoryError:
            error, error_type, remember = (f"could not rig: needed more than the {ASSET_MEMORY >> 30} GB of memory "
                                           f"a worker may use"), "RigFailedError", False
        except Exception as e:  # a bug in autorig: report it, and try again on the next run
            error, error_type, remember = f"internal error: {type(e).__name__}: {e}", type(e).__name__, False
        # Messages name the scratch copy; name the asset instead, and always.
        error = " ".join(error.replace(str(mesh), job.name).replace(str(source) + os.sep, "").split())
        if job.name not in error:
            error = f"{job.name}: {error}"
        return {"status": "failed", "remember": remember, "error": error, "error_type": error_type,
                "seconds": time.perf_counter() - start}


class _TimedOut(BaseException):
    """Raised in a worker by its alarm: a BaseException, so that no ``except Exception`` on the way swallows it."""


@contextlib.contextmanager
def _time_limit(seconds: float | None):
    """Raise ``_TimedOut`` in the block after ``seconds`` (in the main thread on POSIX; elsewhere no limit).
    A blocking call (opening a FIFO) is interrupted too; a long call into C ends first."""
    import signal
    import threading
    if not seconds or not hasattr(signal, "setitimer") or threading.current_thread() is not threading.main_thread():
        yield
        return

    def alarm(signum, frame):
        raise _TimedOut()

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def start_worker(parent: int, memory: int | None = ASSET_MEMORY) -> None:
    """A local worker's first step: end with its parent (the batch), however that ends, SIGKILL included, so
    that killed batches leave no workers waiting on their pipes for ever; and cap its memory at ``memory``
    bytes of address space, so that an asset that would need more fails alone (MemoryError)."""
    import sys
    import threading
    if sys.platform.startswith("linux"):
        import ctypes
        import signal
        try:  # PR_SET_PDEATHSIG: the kernel sends SIGKILL when the parent ends
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:  # it ended before the call above took hold
        os._exit(1)

    def watch():  # where PR_SET_PDEATHSIG is not available: poll
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="autorig-parent-watch").start()
    if memory:
        try:
            import resource
            soft, hard = resource.getrlimit(resource.RLIMIT_AS)
            if soft == resource.RLIM_INFINITY or soft > memory:
                resource.setrlimit(resource.RLIMIT_AS, (memory, hard))
        except (ImportError, ValueError, OSError):
            pass


def remove_stale_scratch() -> None:
    """Remove the scratch folders (``rig_one``'s) that workers of killed batches left in the temporary folder:
    those named by a process that no longer runs."""
    import re
    import shutil
    folder = tempfile.gettempdir()
    try:
        names = os.listdir(folder)
    except OSError:
        return
    for name in names:
        match = re.fullmatch(re.escape(SCRATCH_PREFIX) + r"(\d+)-\w+", name)
        if match is None or _running(int(match.group(1))):
            continue
        path = os.path.join(folder, name)
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path, ignore_errors=True)


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # someone else's process
    return True


def _thumbnails_of(rig) -> dict[str, bytes]:
    """{view: WebP bytes} of ``rig``, or {} if they cannot be drawn (a cluster worker without Pillow, or a
    bug in the drawing): the rig itself is fine, so the asset is not failed for it; its card says so."""
    try:
        from ..show.thumbnails import render_thumbnails
        return render_thumbnails(rig)
    except Exception:
        return {}


def run_locally(jobs: int, work: Iterator[tuple[Plan, Job]], finished) -> None:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")
    with _one_thread_per_worker():
        broken = True
        while broken:  # a crashed worker breaks the whole pool: the rest of the work goes to a new one
            with ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=start_worker,
                                     initargs=(os.getpid(),)) as executor:
                try:
                    broken = drain(executor, 2 * jobs, work, finished,
                                   lost_message="worker process died (crashed or killed) while rigging this asset "
                                                "or one beside it; rerun with -j 1 to tell which")
                except KeyboardInterrupt:
                    _stop_workers(executor)
                    raise


@contextlib.contextmanager
def _workers_ignore_ctrl_c():
    """While a submit may start a worker process: SIGINT ignored, which a spawned Python keeps. A terminal's
    Ctrl-C reaches every process of its group; the workers would each print a KeyboardInterrupt traceback (one
    still importing autorig did), while this process stops them itself (``_stop_workers``)."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _stop_workers(executor) -> None:
    """Ctrl-C: end the pool's workers now rather than when their rigs end (a worker deep in libigl's C code
    sees its own SIGINT only when the call returns: a 48k-vertex batch took 14 s to stop). Their assets are
    not remembered, so the next run rigs them; what they had half-written is removed as after a kill."""
    processes = list((getattr(executor, "_processes", None) or {}).values())   # no public handle before 3.14
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=1)
    executor.shutdown(wait=False, cancel_futures=True)


def drain(executor, window: int, work: Iterator[tuple[Plan, Job]], finished, lost_message: str) -> bool:
    """Keep ``window`` jobs in flight on ``executor`` until ``work`` runs out, handing each outcome to
    ``finished``. A job that the executor could not run (its worker died, the cluster lost it) fails with
    ``lost_message`` and is not remembered. Returns True, and stops taking work, if a local process pool
    broke; the jobs in flight then fail."""
    from concurrent.futures.process import BrokenProcessPool

    pending: dict = {}
    broken = False
    while True:
        while not broken and len(pending) < window:
            item = next(work, None)
            if item is None:
                break
            with _workers_ignore_ctrl_c():
                pending[executor.submit(rig_one, item[1])] = item[0]
        if not pending:
            return broken
        done, _ = wait(pending, return_when=FIRST_COMPLETED)
        for future in sorted(done, key=lambda f: pending[f].rel):
            plan = pending.pop(future)
            try:
                outcome = future.result()
            except Exception as e:
                broken = broken or isinstance(e, BrokenProcessPool)
                detail = " ".join(str(e).split())
                outcome = {"status": "failed", "remember": False, "error_type": type(e).__name__,
                           "error": f"{plan.rel}: {lost_message}" + (f" ({type(e).__name__}: {detail})"
                                                                     if detail else "")}
            finished(plan, outcome)


@contextlib.contextmanager
def _one_thread_per_worker():
    """Start worker processes with one thread per numerical library (see the module docstring). Spawned
    children copy this process's environment when they start, which is the only time those libraries read
    it, so it is set here around the pool and restored afterwards."""
    saved = {name: os.environ.get(name) for name in _THREAD_VARIABLES}
    os.environ.update({name: "1" for name, value in saved.items() if value is None})
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)


def cpu_count() -> int:
    """CPUs this process may run on (fewer than the machine's in a container or under taskset)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def require_thumbnails() -> None:
    """The review page's thumbnails need Pillow: say so before any rigging (exit code 9, as for --preview)."""
    import importlib.util
    if importlib.util.find_spec("PIL") is None:
        raise missing_package("the review page (--html) for its pictures", "Pillow", "preview")
