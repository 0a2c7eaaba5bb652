"""Rig every mesh in a folder: in parallel on this machine or on a Dask cluster, resumable, with reports.

    from autorig.batch import rig_folder
    result = rig_folder("assets/", "rigged/", "biped", jobs=2, report="report.json", junit="report.xml")
    result.exit_code, [(a.input, a.status, a.error) for a in result.assets]

The command line is ``autorig batch INPUT_DIR -o OUTPUT_DIR`` (``autorig batch --help``).

``rig_folder`` below is the batch's spine, one line per step; each step lives in its own module:

    plan     what to rig: the meshes, their options from the command line and ``autorig.toml``, resume keys
    store    the manifest (resume), the outputs and thumbnails written atomically
    lock     one batch at a time per output folder; what a killed one left half-written removed
    worker   one asset rigged from the bytes sent to it, and the local process pool
    cluster  the same on a Dask cluster
    report   the JSON and JUnit reports; review: the page to review the batch by eye
    result   ``AssetResult`` and ``BatchResult``; progress: what ``autorig batch`` prints while it runs

Finding the work
    Every file under ``input_dir`` (recursively; hidden files and folders, and ``output_dir`` when it lies
    inside ``input_dir``, are left out; symlinked folders are not followed) whose extension is one of
    ``extensions`` is an asset. Results and reports list assets in the order of their relative paths,
    compared folder by folder; rigging starts with the slow ones (by their time in the last run, else the
    largest inputs), so that no worker is left with a long asset at the end while the others idle. Each
    asset's output mirrors its place: ``input_dir/a/hero.obj`` -> ``output_dir/a/hero.rigged.glb``; two
    inputs in one folder with the same stem (``hero.obj``, ``hero.ply``) keep their extension in the output
    name instead (``hero.obj.rigged.glb``, ``hero.ply.rigged.glb``).

Per-asset options: ``autorig.toml`` (or ``autorig.json``) in ``input_dir`` or any folder below it::

    template = "quadruped"        # defaults for every asset in this folder and below
    up = "y"
    front = "x"

    [files."horse*.obj"]          # assets matching a glob, relative to this file's folder
    template = "horse"
    up = "z"
    front = "y"

    [files."bipeds/*"]
    skeleton = "rigs/studio.glb"  # the artists' own skeleton: only skin weights (``autorig.pipeline.skin``)

    [files."octopus*"]
    template = "auto"             # a skeleton made from the shape itself

The JSON form is the same document: ``{"template": "quadruped", "files": {"horse*.obj": {"template": "horse"}}}``.
Keys are ``template`` (a built-in name, ``auto``, or a ``.json`` template file relative to the config's folder),
``skeleton`` (a ``.json``, ``.glb``/``.gltf`` or ``.bvh`` skeleton file relative to the config's folder, as for
``autorig MESH --skeleton FILE``), ``up`` and ``front`` (``x``, ``-z``, ... or ``auto`` to detect it, as on the
command line). A glob without ``/`` matches the file name in this folder or any folder below; a glob with ``/``
matches the path relative to the config's folder; ``*`` also matches ``/``; matching is case-sensitive.
The input folder's own config may also set ``html = "review.html"`` at its top: the review page (see Reports),
relative to the output folder, as if given as ``html`` (which wins).

Options cascade as in EditorConfig, each key on its own: the command line's ``--template`` (or ``--skeleton``),
``--up`` and ``--front`` first, then each config from ``input_dir`` down to the asset's folder (so the nearest
config wins), and within one config its top-level keys, then the matching ``files`` entries in the order
written (a later match wins). ``template`` and ``skeleton`` are alternatives, settled together: setting one
drops the other one inherited, and one table may not set both. With a skeleton, up and front do not apply
(reported as ""); the skeleton's scale (``SkinOptions``, ``--skeleton-scale``) and template "auto"'s voxels and
max_segments (``RigOptions``, ``--voxels``, ``--max-segments``) come from the command line, for every asset. A
malformed config, an unknown key or template, an unreadable skeleton or a bad axis stops the batch before any
rigging (``ConfigError``, ``TemplateError``, ``SkeletonError``); skeleton files are read once each, here, and
travel to the workers parsed.

Resuming
    ``output_dir/.autorig-batch.json`` (the manifest) keeps, per asset, a key: the SHA-256 of the input's
    bytes (a ``.gltf`` with the buffers and images it names), of the effective template's content, up, front
    (for template "auto": voxels and max_segments instead of the content; with a skeleton: the skeleton's
    content, glTF nodes included, and its scale instead of all these), the output format and the autorig
    version. Editing a skeleton file thus rigs again the assets that use it, and ``--voxels`` only those on
    "auto". An asset whose key is unchanged is skipped (status ``skipped``, ``previous`` telling how it went)
    unless ``force``; that holds for failures too, since rigging is deterministic: an unchanged asset fails
    the same way again. A skipped asset that had rigged is skipped only while its output still exists.
    Crashed or lost workers and internal errors are not remembered, so a rerun tries those assets again.
    Entries of assets no longer found stay (a narrower ``extensions`` must not forget them). Outputs are
    written without timings (they go to the report instead), so rigging the same asset again, here or on a
    cluster, gives byte-identical files.

Crash safety
    A batch killed at any moment (SIGKILL included) and run again ends with the outputs and report of a run
    never interrupted (assets done before the kill reported ``skipped``, ``previous`` ``ok``): every output,
    thumbnail and the manifest is written to a hidden temporary and renamed into place, the manifest only
    ever names outputs already written, and the next run removes the temporaries a kill left
    (``autorig.batch.lock``). Only one batch at a time writes into an output folder: a second one started
    while the first runs stops at once with ``OutputError`` (exit 4), before any work.

Files from the asset's own folder
    Each asset may read only the files in its own folder and below it (``autorig.input.confine``): textures, MTL
    files, glTF buffers and images named outside it are left out with a warning (``AssetResult.dropped``),
    as is the asset itself when it is a symlink leading out of ``input_dir``, and a config's template and
    skeleton files must lie inside ``input_dir``: unless ``options.allow_outside_paths``. Even then a
    texture named by ``..`` is not sent along to the worker (only the asset's own folder travels); an
    absolute path is read where the worker runs.

Failures
    One failing asset never stops the batch: it gets status ``failed`` and its one-line error (so does one
    that asks for Pinocchio output with a skeleton of several roots, which that format cannot hold). An asset
    that rigged before and fails now loses its old output, which no longer matches its input. Each asset is
    planned, read and rigged on its own: whatever its reader does, it fails alone; a local worker gives it at
    most ``worker.ASSET_SECONDS`` (600 s) and ``worker.ASSET_MEMORY`` (8 GB of address space), and ends with
    the batch however the batch ends (``worker.start_worker``).
    ``BatchResult.exit_code`` is 0 when every asset is rigged (now or in an earlier run) and
    ``EXIT_SOME_FAILED`` (7) when any asset failed, now or, unchanged since, in an earlier run. A rig whose
    confidence is below 0.5 is "doubtful" (``autorig.explain``): rigged, but probably wrong; with
    ``fail_on_doubtful`` such rigs make the code ``EXIT_DOUBTFUL`` (8) when nothing failed.

Reports
    ``report`` (JSON), ``junit`` (JUnit XML) and ``html`` (a page to review the batch by eye:
    ``autorig.batch.review``) are written at the end, atomically; each may lie inside ``output_dir``, in
    folders that do not exist yet. With ``html`` the workers also draw each rig's front and side thumbnails
    (``autorig.show.thumbnails.render_thumbnails``, its ``thumbnails`` stage time) into
    ``output_dir/.autorig-thumbnails/``, and the manifest keeps them, with the stage times and the
    confidence's parts, so that a resumed run's page still shows the skipped assets in full.

Parallelism
    Locally, a process pool of ``jobs`` workers started with 'spawn' (forking a process that has threads is
    unsafe). With ``scheduler="tcp://host:port"`` the assets go to an existing Dask distributed cluster
    (``pip install 'autorig[cluster]'``); its workers need the same autorig version, and read and write no
    files: the inputs' bytes travel with the tasks and the outputs' bytes come back, so the cluster needs no
    shared file system and this process alone writes into ``output_dir``. Worker processes run numerical
    libraries with one thread each (OMP/MKL/OPENBLAS/IGL_NUM_THREADS=1 unless already set, as Dask's own
    nanny does for the first three): it avoids oversubscribing the cores, is faster per rig even alone, and
    keeps local and cluster results alike.
"""
from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Callable, Iterable, Iterator

from ..errors import InputError, OutputError
from .cluster import ClusterError, run_on_cluster
from .lock import LOCK_NAME, output_lock, remove_temporaries
from .plan import (CONFIG_NAMES, DEFAULT_EXTENSIONS, ConfigError, Plan, find_meshes, html_setting, input_files,
                   plan_assets)
from .report import write_json_report, write_junit_report
from .result import EXIT_DOUBTFUL, EXIT_SOME_FAILED, AssetResult, BatchResult
from .store import (MANIFEST_INTERVAL, MANIFEST_NAME, THUMBNAILS_FOLDER, check_writable, kept_result, make_parent,
                    read_manifest, store_outcome, write_manifest)
from .worker import Job, cpu_count, remove_stale_scratch, require_thumbnails, run_locally

__all__ = ["rig_folder", "find_meshes", "BatchResult", "AssetResult", "ConfigError", "ClusterError",
           "write_json_report", "write_junit_report", "DEFAULT_EXTENSIONS", "CONFIG_NAMES", "MANIFEST_NAME",
           "THUMBNAILS_FOLDER", "LOCK_NAME", "EXIT_SOME_FAILED",
           "EXIT_DOUBTFUL"]


def rig_folder(input_dir: str | os.PathLike, output_dir: str | os.PathLike, template: str = "biped",
               options=None, *, skeleton: str | os.PathLike | None = None, skin_options=None,
               fmt: str = "glb", extensions: Iterable[str] = DEFAULT_EXTENSIONS,
               jobs: int | None = None, scheduler: str | None = None, force: bool = False,
               report: str | os.PathLike | None = None, junit: str | os.PathLike | None = None,
               html: str | os.PathLike | None = None, names: str = "template", fail_on_doubtful: bool = False,
               on_start: Callable[[int, int], None] | None = None,
               on_result: Callable[[AssetResult], None] | None = None) -> BatchResult:
    """Rig every mesh under ``input_dir`` into ``output_dir`` (see the module docstring).

    template, options  the default template (a name, a file, or "auto") that config files override, and the
                       ``RigOptions``: up and front, defaults that config files override, and template
                       "auto"'s voxels and max_segments, for every asset that uses "auto"
    skeleton           a skeleton file (.json, .glb/.gltf, .bvh) for every asset that no config gives a
                       template or another skeleton, in place of ``template``
    skin_options       the ``SkinOptions`` (scale) for every asset rigged with a skeleton
    fmt                output format, one of ``autorig.exchange.FORMATS``
    extensions         file extensions that count as meshes (without the dot, any case)
    jobs               local worker processes (default: the CPUs this process may use)
    scheduler          address of a Dask scheduler, e.g. ``tcp://10.0.0.5:8786``, instead of local processes
    force              rig every asset even if unchanged since the last run
    report, junit      where to write the JSON and JUnit XML reports (atomically), if anywhere; a path inside
                       ``output_dir`` may lie in folders that do not exist yet
    html               where to write the review page (``autorig.batch.review``), if anywhere; default the
                       ``html`` of ``input_dir``'s own config file. The workers then draw each rig's thumbnails
                       (needs Pillow), kept in ``output_dir/.autorig-thumbnails``
    names              the output's joint names, one of ``autorig.naming.NAME_SCHEMES`` (the engines' schemes:
                       biped and humanoid only; an asset with other joints fails)
    fail_on_doubtful   the result's exit code is ``EXIT_DOUBTFUL`` (8) when no asset failed but some rig is
                       doubtful (``autorig.explain``: confidence below 0.5), and the JUnit report fails them
    on_start           called once before rigging with (assets to rig, assets skipped)
    on_result          called with each finished or skipped asset's ``AssetResult``, in the order they end

    Raises ``InputError``/``ConfigError`` (exit 2), ``TemplateError``/``SkeletonError`` (3), ``OutputError`` (4),
    ``ClusterError`` (1) or ``MissingPackageError`` (9: ``html`` without Pillow, ``scheduler`` without
    dask.distributed) for problems that stop the whole
    batch, all before any rigging; a failing asset only gets status ``failed``.
    """
    from ..exchange import FORMATS
    from ..pipeline import RigOptions, SkinOptions

    start = time.perf_counter()
    options = options or RigOptions()
    skin_options = skin_options or SkinOptions()
    if fmt not in FORMATS:
        raise OutputError(f"unknown output format {fmt!r}: choose one of {', '.join(FORMATS)}")
    if jobs is not None and jobs < 1:
        raise InputError(f"jobs must be at least 1, not {jobs}")
    input_dir, output_dir = Path(input_dir), Path(output_dir)
    if not input_dir.is_dir():
        raise InputError(f"{input_dir}: {'not a folder' if input_dir.exists() else 'no such folder'}")
    if output_dir.resolve() == input_dir.resolve():
        raise InputError(f"{output_dir}: the output folder must not be the input folder")
    if html is None:
        html = html_setting(input_dir, output_dir, options.allow_outside_paths or skin_options.allow_outside_paths)
    if html is not None:
        require_thumbnails()
    for path in (report, junit, html):
        if path is not None:
            check_writable(Path(path), output_dir)
    try:
        output_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"cannot write {output_dir}: {e.strerror or e}") from None

    # One batch at a time in an output folder; what a killed one left half-written goes first (batch/lock.py).
    with output_lock(output_dir):
        remove_temporaries(output_dir)
        remove_stale_scratch()
        plans = plan_assets(input_dir, output_dir, template, options, fmt, extensions, skeleton, skin_options, names)
        manifest_path = output_dir / MANIFEST_NAME
        manifest = read_manifest(manifest_path)
        results: dict[str, AssetResult] = {}
        todo: list[Plan] = []
        for plan in plans:
            kept = None if force else kept_result(plan, manifest.get(plan.rel), output_dir)
            if kept:
                results[plan.rel] = kept
            else:
                todo.append(plan)

        if on_start:
            on_start(len(todo), len(results))
        for plan in plans:
            if on_result and plan.rel in results:
                on_result(results[plan.rel])

        saved = time.monotonic()

        def finished(plan: Plan, outcome: dict) -> None:
            nonlocal saved
            results[plan.rel] = result = store_outcome(plan, outcome, input_dir, output_dir, fmt, manifest,
                                                       thumbnails=html is not None)
            if on_result:
                on_result(result)
            if time.monotonic() - saved > MANIFEST_INTERVAL:
                write_manifest(manifest_path, manifest)
                saved = time.monotonic()

        # Slowest first, so that the last worker does not finish long after the others: assets rigged before
        # by their last time, those never timed (new ones, which may be big) before them by size. File size
        # alone misjudges small but hard shapes (a 62-vertex rig 0.9 s, a spider 1.4 s, beside a 50k-face
        # statue's 0.5 s).
        def expected(plan: Plan):
            seconds = manifest.get(plan.rel, {}).get("seconds")
            return (0, -plan.size, plan.rel) if seconds is None else (1, -seconds, plan.rel)

        order = sorted(todo, key=expected)

        def jobs_of() -> Iterator[tuple[Plan, Job]]:
            for plan in order:
                try:
                    files = input_files(input_dir / plan.rel, input_dir, plan.options.allow_outside_paths,
                                        markers=getattr(plan.options, "markers", None) is not None)
                    yield plan, Job(plan.rel, files, plan.template, plan.skeleton, plan.options, fmt, names=names,
                                    thumbnails=html is not None)
                except InputError as e:  # unreadable, or gone since it was found
                    finished(plan, {"status": "failed", "remember": False, "error": str(e),
                                    "error_type": "InputError"})
                except Exception as e:  # a bug reading this asset: it fails alone, the batch goes on
                    finished(plan, {"status": "failed", "remember": False, "error_type": type(e).__name__,
                                    "error": f"{plan.rel}: internal error: {type(e).__name__}: {e}"})

        try:
            if todo:
                if scheduler:
                    run_on_cluster(scheduler, jobs_of(), finished)
                else:
                    run_locally(jobs or cpu_count(), jobs_of(), finished)
        finally:
            write_manifest(manifest_path, manifest)

        result = BatchResult(input_dir, output_dir, [results[p.rel] for p in plans], time.perf_counter() - start,
                             fail_on_doubtful)
        for path, write in ((report, write_json_report), (junit, write_junit_report), (html, _write_review)):
            if path is not None:
                make_parent(Path(path), output_dir)
                write(result, path)
        return result


def _write_review(result: BatchResult, path: str | os.PathLike) -> None:
    """The review page, its module loaded only for a batch that asks for one."""
    from .review import write_review
    write_review(result, path)
