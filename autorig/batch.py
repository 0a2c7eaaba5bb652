"""Rig every mesh in a folder: in parallel on this machine or on a Dask cluster, resumable, with reports.

    from autorig.batch import rig_folder
    result = rig_folder("assets/", "rigged/", "biped", jobs=2, report="report.json", junit="report.xml")
    result.exit_code, [(a.input, a.status, a.error) for a in result.assets]

The command line is ``autorig batch INPUT_DIR -o OUTPUT_DIR`` (``autorig batch --help``).

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

Failures
    One failing asset never stops the batch: it gets status ``failed`` and its one-line error (so does one
    that asks for Pinocchio output with a skeleton of several roots, which that format cannot hold). An asset
    that rigged before and fails now loses its old output, which no longer matches its input.
    ``BatchResult.exit_code`` is 0 when every asset is rigged (now or in an earlier run) and
    ``EXIT_SOME_FAILED`` (7) when any asset failed, now or, unchanged since, in an earlier run.

Reports
    ``report`` (JSON), ``junit`` (JUnit XML) and ``html`` (a page to review the batch by eye:
    ``autorig.batch_review``) are written at the end, atomically; each may lie inside ``output_dir``, in
    folders that do not exist yet. With ``html`` the workers also draw each rig's front and side thumbnails
    (``autorig.preview.render_thumbnails``, its ``thumbnails`` stage time) into
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

import contextlib
import fnmatch
import hashlib
import json
import os
import tempfile
import time
from collections import Counter
from concurrent.futures import FIRST_COMPLETED, wait
from dataclasses import asdict, dataclass, field
from pathlib import Path, PurePosixPath
from typing import Callable, Iterable, Iterator
from urllib.parse import unquote

from .version import __version__
from .errors import AutorigError, InputError, OutputError, SkeletonError, TemplateError
from .quiet import quiet_libraries

__all__ = ["rig_folder", "find_meshes", "BatchResult", "AssetResult", "ConfigError", "ClusterError",
           "write_json_report", "write_junit_report", "DEFAULT_EXTENSIONS", "CONFIG_NAMES", "MANIFEST_NAME",
           "THUMBNAILS_FOLDER", "EXIT_SOME_FAILED"]

DEFAULT_EXTENSIONS = ("obj", "off", "ply", "stl", "glb", "gltf")
CONFIG_NAMES = ("autorig.toml", "autorig.json")
MANIFEST_NAME = ".autorig-batch.json"
THUMBNAILS_FOLDER = ".autorig-thumbnails"  # in the output folder: hidden, so a later batch of it skips them
EXIT_SOME_FAILED = 7  # some of the batch's assets failed (6 is rig --strict's low confidence)

_CONFIG_KEYS = ("template", "skeleton", "up", "front")
_BATCH_KEYS = ("html",)  # only in the input folder's own config: the review page, relative to the output folder
_MANIFEST_VERSION = 1
_MANIFEST_INTERVAL = 2.0  # seconds between manifest saves while running, so an interrupted batch resumes
# libigl's own thread pool (its AABB distance queries and winding numbers) reads IGL_NUM_THREADS: without it each
# worker of "-j 2" would start two threads and the pair would fight over the two cores.
_THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "IGL_NUM_THREADS")


class ConfigError(InputError):
    """A per-folder config file that cannot be used (exit code 2)."""


class ClusterError(AutorigError):
    """Cluster mode cannot run: dask.distributed missing, the scheduler unreachable, or workers unfit."""
    exit_code = 1


@dataclass
class AssetResult:
    """What happened to one asset.

    input       path relative to the input folder (``/``-separated)
    output      path of its output relative to the output folder
    status      ``ok`` (rigged now), ``failed`` (now) or ``skipped`` (unchanged since an earlier run)
    previous    for ``skipped``: ``ok`` or ``failed``, the outcome that is kept; else None
    template    name of the template used (``auto`` for the template-free skeleton), or ``skeleton FILE`` for
                the user's skeleton FILE (relative to the input folder when inside it)
    up, front   the axes used ("" with a skeleton: they do not apply)
    error       the one-line error of a failure (also of a skipped earlier failure), naming the asset
    error_type  the error's class name (``InputError``, ``RigFailedError``, ...), else None
    confidence  ``rig.info["confidence"]`` when the pipeline reports one, else None
    confidence_parts  ``rig.info["confidence_parts"]``, what the confidence is the product of, else {}
    seconds     wall time of the work on this asset, transfer included (0 when skipped)
    timings     {stage: seconds} of the pipeline and the ``write`` stage ({} when skipped)
    previous_timings  for ``skipped``: the ``timings`` of the run that rigged it, else {}
    thumbnails  {view: path} of its small pictures (WebP; "front" and "side", or "top" and one of those for a
                flat shape) relative to the output folder, when
                a run with ``html`` drew them (kept for skipped assets), else {}
    """
    input: str
    output: str
    status: str
    template: str
    up: str
    front: str
    previous: str | None = None
    error: str | None = None
    error_type: str | None = None
    confidence: float | None = None
    seconds: float = 0.0
    timings: dict[str, float] = field(default_factory=dict)
    confidence_parts: dict[str, float] = field(default_factory=dict)
    previous_timings: dict[str, float] = field(default_factory=dict)
    thumbnails: dict[str, str] = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        """Whether the asset has no rig: it failed now, or failed before and is unchanged since."""
        return self.status == "failed" or self.previous == "failed"


@dataclass
class BatchResult:
    """The outcome of ``rig_folder``: one ``AssetResult`` per asset, in the order assets are found."""
    input_dir: Path
    output_dir: Path
    assets: list[AssetResult]
    seconds: float

    @property
    def counts(self) -> dict[str, int]:
        """{"ok": n, "failed": n, "skipped": n} by ``status``."""
        counts = Counter(a.status for a in self.assets)
        return {status: counts[status] for status in ("ok", "failed", "skipped")}

    @property
    def exit_code(self) -> int:
        """0 when every asset has a rig, ``EXIT_SOME_FAILED`` when any has none (see ``AssetResult.failed``)."""
        return EXIT_SOME_FAILED if any(a.failed for a in self.assets) else 0


@dataclass(frozen=True)
class _Plan:
    """One asset's work: where it is, where it goes, how (a template, or a skeleton, with the options for it),
    what the report calls that (``label``), its resume key ("" when the input could not be read), and its
    input's size in bytes."""
    rel: str
    output: str
    template: object  # a loaded autorig.template.Template, or template.AUTO; None with a skeleton
    skeleton: object  # an autorig.exchange.skeleton.Skeleton, or None
    options: object   # the RigOptions (template) or SkinOptions (skeleton) to rig it with
    label: str
    up: str           # "" with a skeleton
    front: str
    key: str
    size: int


@dataclass(frozen=True)
class _Job:
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


def rig_folder(input_dir: str | os.PathLike, output_dir: str | os.PathLike, template: str = "biped",
               options=None, *, skeleton: str | os.PathLike | None = None, skin_options=None,
               fmt: str = "glb", extensions: Iterable[str] = DEFAULT_EXTENSIONS,
               jobs: int | None = None, scheduler: str | None = None, force: bool = False,
               report: str | os.PathLike | None = None, junit: str | os.PathLike | None = None,
               html: str | os.PathLike | None = None, names: str = "template",
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
    html               where to write the review page (``autorig.batch_review``), if anywhere; default the
                       ``html`` of ``input_dir``'s own config file. The workers then draw each rig's thumbnails
                       (needs matplotlib), kept in ``output_dir/.autorig-thumbnails``
    names              the output's joint names, one of ``autorig.naming.NAME_SCHEMES`` (mixamo: biped only;
                       an asset with other joints fails)
    on_start           called once before rigging with (assets to rig, assets skipped)
    on_result          called with each finished or skipped asset's ``AssetResult``, in the order they end

    Raises ``InputError``/``ConfigError`` (exit 2), ``TemplateError``/``SkeletonError`` (3), ``OutputError`` (4),
    ``ClusterError`` (1) or ``AutorigError`` (1: ``html`` without matplotlib) for problems that stop the whole
    batch, all before any rigging; a failing asset only gets status ``failed``.
    """
    from .exchange import FORMATS
    from .pipeline import RigOptions, SkinOptions

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
        html = _html_setting(input_dir, output_dir)
    if html is not None:
        _require_thumbnails()
    for path in (report, junit, html):
        if path is not None:
            _check_writable(Path(path), output_dir)
    try:
        output_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"cannot write {output_dir}: {e.strerror or e}") from None

    plans = _plan(input_dir, output_dir, template, options, fmt, extensions, skeleton, skin_options, names)
    manifest_path = output_dir / MANIFEST_NAME
    manifest = _read_manifest(manifest_path)
    results: dict[str, AssetResult] = {}
    todo: list[_Plan] = []
    for plan in plans:
        kept = None if force else _kept_result(plan, manifest.get(plan.rel), output_dir)
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

    def finished(plan: _Plan, outcome: dict) -> None:
        nonlocal saved
        results[plan.rel] = result = _store(plan, outcome, input_dir, output_dir, fmt, manifest,
                                            thumbnails=html is not None)
        if on_result:
            on_result(result)
        if time.monotonic() - saved > _MANIFEST_INTERVAL:
            _write_manifest(manifest_path, manifest)
            saved = time.monotonic()

    # Slowest first, so that the last worker does not finish long after the others: assets rigged before
    # by their last time, those never timed (new ones, which may be big) before them by size. File size
    # alone misjudges small but hard shapes (a 62-vertex rig 0.9 s, a spider 1.4 s, beside a 50k-face
    # statue's 0.5 s).
    def expected(plan: _Plan):
        seconds = manifest.get(plan.rel, {}).get("seconds")
        return (0, -plan.size, plan.rel) if seconds is None else (1, -seconds, plan.rel)

    order = sorted(todo, key=expected)

    def jobs_of() -> Iterator[tuple[_Plan, _Job]]:
        for plan in order:
            try:
                yield plan, _Job(plan.rel, _input_files(input_dir / plan.rel), plan.template, plan.skeleton,
                                 plan.options, fmt, names=names, thumbnails=html is not None)
            except InputError as e:  # unreadable, or gone since it was found
                finished(plan, {"status": "failed", "remember": False, "error": str(e),
                                "error_type": "InputError"})

    try:
        if todo:
            if scheduler:
                _run_on_cluster(scheduler, jobs_of(), finished)
            else:
                _run_locally(jobs or _cpu_count(), jobs_of(), finished)
    finally:
        _write_manifest(manifest_path, manifest)

    result = BatchResult(input_dir, output_dir, [results[p.rel] for p in plans], time.perf_counter() - start)
    for path, write in ((report, write_json_report), (junit, write_junit_report), (html, _write_review)):
        if path is not None:
            _make_parent(Path(path))
            write(result, path)
    return result


# --------------------------------------------------------------------------------------------- finding work

def find_meshes(input_dir: str | os.PathLike, extensions: Iterable[str] = DEFAULT_EXTENSIONS,
                exclude: str | os.PathLike | None = None) -> list[str]:
    """Relative ``/``-separated paths of the mesh files under ``input_dir``, in a deterministic order.

    Hidden files and folders (name starting with '.') and the folder ``exclude`` are left out; symlinks to
    files count, symlinked folders are not entered (they could loop).
    """
    suffixes = {"." + e.lower().lstrip(".") for e in extensions}
    root = Path(input_dir)
    skip = Path(os.path.realpath(exclude)) if exclude is not None else None
    found = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if not d.startswith(".")
                   and (skip is None or Path(os.path.realpath(os.path.join(folder, d))) != skip)]
        rel_folder = PurePosixPath(Path(folder).relative_to(root).as_posix())
        found += [str(rel_folder / name) for name in files
                  if not name.startswith(".") and Path(name).suffix.lower() in suffixes]
    return sorted(found, key=lambda rel: rel.split("/"))


def _plan(input_dir: Path, output_dir: Path, template, options, fmt: str, extensions, skeleton=None,
          skin_options=None, names: str = "template") -> list[_Plan]:
    """Each asset's effective options, output path and resume key; config, template and skeleton errors raise
    here."""
    from dataclasses import replace

    from .exchange import default_output_path
    from .mesh import AxisError, frame_rotation
    from .pipeline import SkinOptions
    from .template import AUTO

    skin_options = skin_options or SkinOptions()
    rels = find_meshes(input_dir, extensions, exclude=output_dir)
    templates, skeletons = _TemplateCache(), _SkeletonCache(input_dir)
    base = {"template": None, "skeleton": None, "up": options.up, "front": options.front}
    if skeleton is not None:
        base["skeleton"] = str(skeleton)
        skeletons.load(base["skeleton"])  # a bad file stops the batch even if every asset chose otherwise
    else:
        base["template"] = templates.resolve(template, Path.cwd())
    for key in ("up", "front"):
        base[key] = _check_axis(base[key], key, "")
    configs = _Configs(input_dir, templates, skeletons)

    outputs = {rel: default_output_path(rel, fmt).as_posix() for rel in rels}
    clashes = Counter(outputs.values())
    for rel, out in outputs.items():
        if clashes[out] > 1:  # hero.obj and hero.ply: keep the extension, hero.obj.rigged.glb
            source = PurePosixPath(rel)
            suffix = PurePosixPath(out).name[len(source.stem):]  # ".rigged.glb"
            outputs[rel] = str(source.with_name(source.name + suffix))
    if len(set(outputs.values())) < len(outputs):
        taken = Counter(outputs.values())
        names = sorted(rel for rel, out in outputs.items() if taken[out] > 1)
        raise InputError(f"{input_dir}: these assets would share an output name: {', '.join(names)}")

    plans = []
    for rel in rels:
        effective = configs.options_for(rel, base)
        if effective["skeleton"] is not None:
            loaded, parsed = None, skeletons.load(effective["skeleton"])
            scale = skin_options.scale
            if scale is None:  # what skin() does with None, spelled out so that the key means the same
                scale = "auto" if parsed.kind == "bvh" else 1.0
            how = replace(skin_options, scale=scale if scale == "auto" else float(scale))
            label, up, front = f"skeleton {skeletons.name_of(effective['skeleton'])}", "", ""
            settings = {"skeleton": skeletons.digest(effective["skeleton"]), "skin": asdict(how)}
        else:
            up, front = effective["up"], effective["front"]
            try:
                if "auto" not in (up, front):
                    frame_rotation(up, front)
            except AxisError as e:
                raise ConfigError(f"{input_dir / rel}: {e} (from {configs.origin_of(rel)})") from None
            loaded, parsed = templates.load(effective["template"]), None
            how = replace(options, up=up, front=front)
            label = AUTO if loaded == AUTO else loaded.name
            content = (_digest({"name": AUTO, "voxels": how.voxels, "max_segments": how.max_segments})
                       if loaded == AUTO else templates.digest(loaded))
            settings = {"template": content, "up": up, "front": front}
        try:
            files = _input_files(input_dir / rel)
        except InputError:
            key, size = "", 0  # fails as that asset's error when it is read again to be rigged
        else:
            key = _digest({"input": {name: hashlib.sha256(data).hexdigest() for name, data in files.items()},
                           **settings, "format": fmt, "autorig": __version__,
                           # only when asked, so that rigs from before --names still count as done
                           **({"names": names} if names != "template" else {})})
            size = sum(map(len, files.values()))
        plans.append(_Plan(rel, outputs[rel], loaded, parsed, how, label, up, front, key, size))
    return plans


class _TemplateCache:
    """Template specs resolved (file templates to absolute paths), loaded and hashed once each."""

    def __init__(self):
        self._loaded: dict[str, object] = {}

    @staticmethod
    def resolve(spec: str, folder: Path) -> str:
        """A built-in name (or ``auto``) stays a name; a file (a spec ending in ``.json`` or holding a path
        separator) becomes an absolute path, relative to ``folder``."""
        spec = str(spec)
        if spec.endswith(".json") or os.sep in spec or "/" in spec:
            return str((folder / spec).resolve())
        return spec

    def load(self, spec: str):
        """The ``Template`` of ``spec``, or ``template.AUTO`` for "auto" (the template-free skeleton, made in the
        worker from each mesh)."""
        from .template import AUTO, load_template
        if spec == AUTO:
            return AUTO
        if spec not in self._loaded:
            self._loaded[spec] = load_template(spec)
        return self._loaded[spec]

    @staticmethod
    def digest(template) -> str:
        """Hash of everything in a template that shapes a rig, so editing a template file reruns its assets."""
        return _digest({"name": template.name, "names": list(template.names),
                        "parents": template.parents.tolist(), "positions": template.positions.tolist(),
                        "symmetry": [list(p) for p in template.symmetry], "feet": list(template.feet),
                        "fat": list(template.fat)})


class _SkeletonCache:
    """Skeleton files, read (and so checked) and hashed once each, by their real path. A path is kept as given
    (the command line's as typed, a config's joined to the config's folder) so that errors name it so."""

    def __init__(self, root: Path):
        self._root = Path(os.path.realpath(root))
        self._loaded: dict[str, tuple[object, str]] = {}  # real path -> (Skeleton, digest)

    def load(self, path: str):
        from .exchange.skeleton import read_skeleton
        real = os.path.realpath(path)
        if real not in self._loaded:
            skeleton = read_skeleton(path)
            nodes = skeleton.joint_nodes
            digest = _digest({
                "names": list(skeleton.names), "parents": skeleton.parents.tolist(),
                "positions": skeleton.positions.tolist(), "tips": skeleton.tips.tolist(), "kind": skeleton.kind,
                "joint_nodes": None if nodes is None else {**asdict(nodes),
                                                           "inverse_bind": nodes.inverse_bind.tolist()}})
            self._loaded[real] = skeleton, digest
        return self._loaded[real][0]

    def digest(self, path: str) -> str:
        """Hash of everything in the skeleton that shapes a rig (NaN tips included), so editing the file reruns
        its assets and nothing else does."""
        self.load(path)
        return self._loaded[os.path.realpath(path)][1]

    def name_of(self, path: str) -> str:
        """How reports name the skeleton: its path relative to the input folder when inside it, else as given."""
        real = Path(os.path.realpath(path))
        if self._root in real.parents:
            return real.relative_to(self._root).as_posix()
        return os.path.normpath(path)


class _Configs:
    """The per-folder config files under an input folder, and the options they give each asset."""

    def __init__(self, root: Path, templates: _TemplateCache, skeletons: _SkeletonCache):
        self.root = root
        self._templates = templates
        self._skeletons = skeletons
        # relative folder ("" for the root) -> (config file, its settings), or None when it has none
        self._by_folder: dict[str, tuple[Path, dict] | None] = {}

    def _config(self, rel_folder: str) -> tuple[Path, dict] | None:
        if rel_folder not in self._by_folder:
            folder = self.root / rel_folder
            present = [folder / name for name in CONFIG_NAMES if (folder / name).is_file()]
            if len(present) > 1:
                raise ConfigError(f"{folder}: both {' and '.join(CONFIG_NAMES)}; keep one")
            self._by_folder[rel_folder] = (present[0], self._parse(present[0])) if present else None
        return self._by_folder[rel_folder]

    def _chain(self, rel: str) -> list[tuple[str, Path, dict]]:
        """(relative folder, file, settings) of the configs that apply to asset ``rel``, farthest first."""
        parts = rel.split("/")[:-1]
        chain = []
        for depth in range(len(parts) + 1):
            rel_folder = "/".join(parts[:depth])
            config = self._config(rel_folder)
            if config:
                chain.append((rel_folder, *config))
        return chain

    def batch_settings(self) -> dict:
        """The settings for the whole batch (``_BATCH_KEYS``) in the input folder's own config."""
        config = self._config("")
        return {key: config[1][key] for key in _BATCH_KEYS if config and key in config[1]}

    def options_for(self, rel: str, base: dict) -> dict:
        effective = dict(base)
        for rel_folder, _, settings in self._chain(rel):
            local = rel[len(rel_folder) + 1:] if rel_folder else rel
            self._apply(effective, settings)
            for glob, entry in settings.get("files", {}).items():
                if fnmatch.fnmatchcase(local if "/" in glob else PurePosixPath(local).name, glob):
                    self._apply(effective, entry)
        return effective

    @staticmethod
    def _apply(effective: dict, settings: dict) -> None:
        """One table's settings over ``effective``: key by key, but a template drops an inherited skeleton and
        a skeleton an inherited template (they are two ways of saying which skeleton)."""
        effective.update({k: v for k, v in settings.items() if k in _CONFIG_KEYS})
        if "template" in settings:
            effective["skeleton"] = None
        if "skeleton" in settings:
            effective["template"] = None

    def origin_of(self, rel: str) -> str:
        chain = self._chain(rel)
        return str(chain[-1][1]) if chain else "the command line"

    def _parse(self, path: Path) -> dict:
        try:
            if path.suffix == ".toml":
                try:
                    import tomllib
                except ModuleNotFoundError:  # Python 3.10
                    import tomli as tomllib
                with open(path, "rb") as f:
                    data = tomllib.load(f)
            else:
                data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as e:  # TOMLDecodeError and JSONDecodeError too
            raise ConfigError(f"{path}: {' '.join(str(e).split())}") from None
        if not isinstance(data, dict):
            raise ConfigError(f"{path}: expected a table of settings")
        settings = self._settings(data, path, allowed=(*_CONFIG_KEYS, *_BATCH_KEYS, "files"), where="")
        for key in _BATCH_KEYS:
            if key in data:
                if path.parent != self.root:
                    raise ConfigError(f"{path}: {key} is set for the whole batch, in the input folder's own "
                                      f"{path.name}, not in a folder below it")
                if not isinstance(data[key], str) or not data[key]:
                    raise ConfigError(f"{path}: {key} must be a file name, not {data[key]!r}")
                settings[key] = data[key]
        files = data.get("files", {})
        if not isinstance(files, dict):
            raise ConfigError(f"{path}: files: expected a table of glob = {{settings}}")
        settings["files"] = {glob: self._settings(entry, path, _CONFIG_KEYS, f"files.{glob!r}: ")
                             for glob, entry in files.items()}
        return settings

    def _settings(self, data, path: Path, allowed, where: str) -> dict:
        if not isinstance(data, dict):
            raise ConfigError(f"{path}: {where}expected a table of settings")
        unknown = sorted(set(data) - set(allowed))
        if unknown:
            raise ConfigError(f"{path}: {where}unknown key {unknown[0]!r}; use {', '.join(allowed)}")
        if "template" in data and "skeleton" in data:
            raise ConfigError(f"{path}: {where}template and skeleton are alternatives (a template to embed, or "
                              f"your own skeleton); set one")
        settings = {}
        for key in _CONFIG_KEYS:
            if key in data:
                if not isinstance(data[key], str):
                    raise ConfigError(f"{path}: {where}{key} must be a string, not {data[key]!r}")
                settings[key] = (data[key] if key in ("template", "skeleton")
                                 else _check_axis(data[key], key, f"{path}: {where}"))
        if "template" in settings:
            settings["template"] = self._templates.resolve(settings["template"], path.parent)
            try:
                self._templates.load(settings["template"])
            except TemplateError as e:
                raise TemplateError(f"{path}: {where}{e}") from None
        if "skeleton" in settings:
            settings["skeleton"] = os.path.join(path.parent, settings["skeleton"])
            try:
                self._skeletons.load(settings["skeleton"])
            except SkeletonError as e:
                raise SkeletonError(f"{path}: {where}{e}") from None
        return settings


# --------------------------------------------------------------------------------------------- resuming

def _check_axis(spec: str, key: str, where: str) -> str:
    """``spec`` in lower case if it names an axis or is ``auto``, else ``ConfigError``."""
    from .mesh import AxisError, axis_vector
    if spec.lower() == "auto":
        return "auto"
    try:
        axis_vector(spec)
    except AxisError as e:
        raise ConfigError(f"{where}{key}: {e}") from None
    return spec.lower()


def _input_files(path: Path) -> dict[str, bytes]:
    """The bytes a mesh needs, by name relative to its folder: the file itself, first, and for a ``.gltf``
    the external buffers and images it names that exist (a missing one is the loader's error to report)."""
    try:
        files = {path.name: path.read_bytes()}
    except OSError as e:
        raise InputError(f"{path}: cannot read file ({e.strerror or e})") from None
    folder = path.parent.resolve()

    def add(name: str, base: Path = folder) -> Path | None:
        target = (base / name).resolve()
        # Only files beside or below the mesh: they have to fit in a worker's scratch folder.
        if folder in target.parents and target.is_file():
            files[PurePosixPath(target.relative_to(folder).as_posix()).as_posix()] = target.read_bytes()
            return target
        return None

    if path.suffix.lower() == ".gltf":
        try:
            document = json.loads(files[path.name])
        except (ValueError, UnicodeDecodeError):
            return files  # not JSON: the loader will say so
        for item in [*document.get("buffers", []), *document.get("images", [])]:
            uri = item.get("uri") if isinstance(item, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:") or ":" in uri.split("/")[0]:
                continue
            add(unquote(uri))
    elif path.suffix.lower() == ".obj":
        from .look import material_files
        for library, maps in material_files(path):
            if add(library) is not None:
                for name in maps:
                    add(name, (folder / library).parent)
    return files


def _digest(value) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True).encode()).hexdigest()


def _read_manifest(path: Path) -> dict:
    """{relative input: entry} from an earlier run; an absent, unreadable or foreign manifest is empty: then
    everything is rigged again, which is slow but never wrong."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.get("manifest") == _MANIFEST_VERSION and isinstance(data.get("assets"), dict):
            return data["assets"]
    except (OSError, ValueError, AttributeError):
        pass
    return {}


def _write_manifest(path: Path, assets: dict) -> None:
    from .exchange import write_file_atomic
    document = {"manifest": _MANIFEST_VERSION, "autorig": __version__, "assets": dict(sorted(assets.items()))}
    write_file_atomic(path, (json.dumps(document, indent=1) + "\n").encode())


def _kept_result(plan: _Plan, entry: dict | None, output_dir: Path) -> AssetResult | None:
    """The earlier outcome of ``plan`` if it still holds (same key, and the output still there), else None."""
    if not entry or entry.get("key") != plan.key or entry.get("output") != plan.output:
        return None
    if entry.get("status") == "ok" and not (output_dir / plan.output).exists():
        return None
    thumbnails = {view: rel for view, rel in (entry.get("thumbnails") or {}).items()
                  if (output_dir / rel).is_file()}
    return AssetResult(input=plan.rel, output=plan.output, status="skipped", previous=entry.get("status"),
                       template=plan.label, up=plan.up, front=plan.front, error=entry.get("error"),
                       error_type=entry.get("error_type"), confidence=entry.get("confidence"),
                       confidence_parts=entry.get("confidence_parts") or {},
                       previous_timings=entry.get("timings") or {}, thumbnails=thumbnails)


def _store(plan: _Plan, outcome: dict, input_dir: Path, output_dir: Path, fmt: str, manifest: dict,
           thumbnails: bool = False) -> AssetResult:
    """Write a finished asset's output (and with ``thumbnails`` its pictures), remember its outcome when it
    would come out the same again, and return its ``AssetResult``."""
    result = AssetResult(input=plan.rel, output=plan.output, status=outcome["status"],
                         template=plan.label, up=plan.up, front=plan.front, error=outcome.get("error"),
                         error_type=outcome.get("error_type"), confidence=outcome.get("confidence"),
                         confidence_parts=outcome.get("confidence_parts", {}),
                         seconds=outcome.get("seconds", 0.0), timings=outcome.get("timings", {}))
    out = output_dir / plan.output
    _remove_thumbnails(output_dir, plan.output)  # of an earlier rig: the new one (or none) replaces them
    if result.status == "ok":
        try:
            _write_output(out, outcome["data"], fmt, input_dir / plan.rel)
            if thumbnails:
                result.thumbnails = _write_thumbnails(output_dir, plan.output, outcome.get("thumbnails", {}))
        except AutorigError as e:
            result.status, result.error, result.error_type = "failed", str(e), type(e).__name__
            result.confidence, result.confidence_parts = None, {}
            outcome = {"remember": False}
    elif plan.rel in manifest and manifest[plan.rel].get("status") == "ok":
        _remove_output(out, fmt)
    if outcome.get("remember"):
        manifest[plan.rel] = {"key": plan.key, "output": plan.output, "status": result.status,
                              "error": result.error, "error_type": result.error_type,
                              "confidence": result.confidence, "seconds": round(result.seconds, 3),
                              "confidence_parts": result.confidence_parts,
                              "timings": {stage: round(s, 4) for stage, s in result.timings.items()},
                              "thumbnails": result.thumbnails}
    else:
        manifest.pop(plan.rel, None)
    return result


def _write_output(out: Path, data: bytes | dict[str, bytes], fmt: str, source: Path) -> None:
    """Write a worker's output bytes (a file's, or {name: bytes} of a Pinocchio folder) to ``out``."""
    from .exchange import check_output, write_file_atomic, write_folder_atomic
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"cannot write {out}: {e.strerror or e}") from None
    check_output(out, fmt, input_path=source)
    if fmt == "pinocchio":
        write_folder_atomic(out, data)
    else:
        write_file_atomic(out, data)


def _thumbnail_path(output: str, view: str) -> str:
    """Where the ``view`` thumbnail of the asset whose output is ``output`` goes, relative to the output folder."""
    return f"{THUMBNAILS_FOLDER}/{output}.{view}.webp"


def _write_thumbnails(output_dir: Path, output: str, pictures: dict[str, bytes]) -> dict[str, str]:
    """Write a worker's {view: WebP bytes}; returns {view: path relative to ``output_dir``}."""
    from .exchange import write_file_atomic
    written = {}
    for view, data in pictures.items():
        rel = _thumbnail_path(output, view)
        _make_parent(output_dir / rel)
        write_file_atomic(output_dir / rel, data)
        written[view] = rel
    return written


def _remove_thumbnails(output_dir: Path, output: str) -> None:
    for view in ("front", "side", "top"):     # the views render_thumbnails draws (top: a flat shape)
        with contextlib.suppress(OSError):
            (output_dir / _thumbnail_path(output, view)).unlink()


def _remove_output(out: Path, fmt: str) -> None:
    """Delete an output this batch wrote earlier (the manifest says so) for an input that now fails."""
    from .exchange.pinocchio import FILES
    with contextlib.suppress(OSError):
        if fmt == "pinocchio" and out.is_dir() and not out.is_symlink():
            for name in FILES:
                with contextlib.suppress(FileNotFoundError):
                    (out / name).unlink()
            out.rmdir()
        elif out.is_file():
            out.unlink()


# --------------------------------------------------------------------------------------------- running

def _rig_one(job: _Job) -> dict:
    """Rig one asset in a worker (a local process or a Dask worker): write its files to a scratch folder,
    rig, write the output there and return the output's bytes. Never raises for a problem with the asset."""
    from .exchange import write_rig
    from .pipeline import rig, skin

    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="autorig-batch-") as scratch, quiet_libraries():
        source = Path(scratch, "in")
        mesh = source / next(iter(job.files))
        try:
            for name, data in job.files.items():
                (source / name).parent.mkdir(parents=True, exist_ok=True)
                (source / name).write_bytes(data)
            if job.skeleton is None:
                result = rig(str(mesh), job.template, job.options)
            else:
                if job.fmt == "pinocchio":
                    # What write_pinocchio would refuse after the work; the command line says so up front.
                    from .exchange.pinocchio import unfit_skeleton
                    problem = unfit_skeleton(job.skeleton.parents)
                    if problem:
                        raise SkeletonError(f"{job.name}: {problem}")
                result = skin(str(mesh), job.skeleton, job.options)
            from .naming import rename_joints
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
                    "seconds": time.perf_counter() - start}
        except AutorigError as e:
            error, error_type, remember = str(e), type(e).__name__, True
        except Exception as e:  # a bug in autorig: report it, and try again on the next run
            error, error_type, remember = f"internal error: {type(e).__name__}: {e}", type(e).__name__, False
        # Messages name the scratch copy; name the asset instead, and always.
        error = " ".join(error.replace(str(mesh), job.name).replace(str(source) + os.sep, "").split())
        if job.name not in error:
            error = f"{job.name}: {error}"
        return {"status": "failed", "remember": remember, "error": error, "error_type": error_type,
                "seconds": time.perf_counter() - start}


def _thumbnails_of(rig) -> dict[str, bytes]:
    """{view: WebP bytes} of ``rig``, or {} if they cannot be drawn (a cluster worker without matplotlib, or a
    bug in the drawing): the rig itself is fine, so the asset is not failed for it; its card says so."""
    try:
        from .preview import render_thumbnails
        return render_thumbnails(rig)
    except Exception:
        return {}


def _run_locally(jobs: int, work: Iterator[tuple[_Plan, _Job]], finished) -> None:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")
    with _one_thread_per_worker():
        broken = True
        while broken:  # a crashed worker breaks the whole pool: the rest of the work goes to a new one
            with ProcessPoolExecutor(max_workers=jobs, mp_context=context) as executor:
                broken = _drain(executor, 2 * jobs, work, finished,
                                lost_message="worker process died (crashed or killed) while rigging this asset "
                                             "or one beside it; rerun with -j 1 to tell which")


def _drain(executor, window: int, work: Iterator[tuple[_Plan, _Job]], finished, lost_message: str) -> bool:
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
            pending[executor.submit(_rig_one, item[1])] = item[0]
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


def _run_on_cluster(address: str, work: Iterator[tuple[_Plan, _Job]], finished) -> None:
    try:
        from distributed import Client
        from distributed.comm import parse_address
        from distributed.comm.registry import get_backend
    except ImportError:
        raise ClusterError("cluster mode needs dask.distributed: pip install 'autorig[cluster]'") from None
    try:
        # Checked first: a Client that fails on a bad scheme hangs the interpreter's exit for a minute.
        get_backend(parse_address(address)[0])
    except ValueError as e:
        raise ClusterError(f"bad Dask scheduler address {address!r}: {e}") from None
    try:
        # Waits distributed.comm.timeouts.connect (30 s; DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT).
        client = Client(address, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as e:
        raise ClusterError(f"cannot reach the Dask scheduler at {address}: {' '.join(str(e).split())}") from None
    with client:
        try:
            versions = client.run(_autorig_version)
        except Exception as e:  # a worker that cannot even import autorig
            raise ClusterError(f"the Dask workers at {address} cannot run autorig: {type(e).__name__}: {e}"
                               ) from None
        wrong = sorted(w for w, v in versions.items() if v != __version__)
        if not versions:
            raise ClusterError(f"the Dask scheduler at {address} has no workers")
        if wrong:
            raise ClusterError(f"Dask workers run another autorig version than {__version__}: "
                               f"{', '.join(f'{w} has {versions[w]}' for w in wrong[:3])}")
        threads = sum(client.nthreads().values())
        with client.get_executor(pure=False) as executor:
            # Dask retries a task whose worker died (distributed.scheduler.allowed-failures) before it
            # gives up with KilledWorker; any error from the cluster itself fails just that asset.
            _drain(executor, max(4, 2 * threads), work, finished,
                   lost_message="the Dask cluster could not run this asset")


def _autorig_version() -> str:
    return __version__


def _cpu_count() -> int:
    """CPUs this process may run on (fewer than the machine's in a container or under taskset)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _check_writable(path: Path, output_dir: Path) -> None:
    """Refuse a report path that cannot be written, before any slow work. Folders inside ``output_dir`` that
    do not exist yet are fine: the batch makes them (``rigged/report.json`` before ``rigged/`` exists)."""
    if path.is_dir():
        raise OutputError(f"cannot write {path}: it is a directory")
    made = Path(os.path.abspath(output_dir))  # with its missing parents
    folder = Path(os.path.abspath(path.parent))
    while not folder.is_dir() and (folder == made or made in folder.parents or folder in made.parents):
        folder = folder.parent
    if not folder.is_dir():
        raise OutputError(f"cannot write {path}: the directory {folder} does not exist")
    if not os.access(folder, os.W_OK):
        raise OutputError(f"cannot write {path}: permission denied in {folder}")


def _make_parent(path: Path) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"cannot write {path}: {e.strerror or e}") from None


def _require_thumbnails() -> None:
    """The review page's thumbnails need matplotlib: say so before any rigging (exit code 1, as for --preview)."""
    import importlib.util
    if importlib.util.find_spec("matplotlib") is None:
        raise AutorigError("the review page (html) needs matplotlib for its pictures: pip install 'autorig[preview]'")


def _html_setting(input_dir: Path, output_dir: Path) -> Path | None:
    """The review page that ``input_dir``'s own config asks for (``html = "review.html"``, relative to the output
    folder), else None."""
    settings = _Configs(input_dir, _TemplateCache(), _SkeletonCache(input_dir)).batch_settings()
    return output_dir / settings["html"] if "html" in settings else None


def _write_review(result: BatchResult, path: str | os.PathLike) -> None:
    from .batch_review import write_review
    write_review(result, path)


# --------------------------------------------------------------------------------------------- reports

def write_json_report(result: BatchResult, path: str | os.PathLike) -> None:
    """Write ``result`` as JSON, atomically::

        {"autorig": "0.1.0", "input": "/abs/assets", "output": "/abs/rigged", "seconds": 12.5,
         "summary": {"total": 4, "ok": 2, "failed": 1, "skipped": 1, "exit_code": 6},
         "assets": [{"input": "dogs/rex.obj", "output": "dogs/rex.rigged.glb", "status": "ok",
                     "previous": null, "template": "quadruped", "up": "y", "front": "z", "error": null,
                     "error_type": null, "confidence": 0.82, "seconds": 3.1, "timings": {"load": 0.1, ...},
                     "confidence_parts": {"fit": 0.9, ...}, "previous_timings": {}, "thumbnails": {}},
                    ...]}
    """
    from .exchange import write_file_atomic
    document = {"autorig": __version__, "input": str(result.input_dir.resolve()),
                "output": str(result.output_dir.resolve()), "seconds": round(result.seconds, 3),
                "summary": {"total": len(result.assets), **result.counts, "exit_code": result.exit_code},
                "assets": [_json_asset(a) for a in result.assets]}
    write_file_atomic(path, (json.dumps(document, indent=1) + "\n").encode())


def _json_asset(asset: AssetResult) -> dict:
    document = asdict(asset)
    document["seconds"] = round(asset.seconds, 3)
    document["timings"] = {stage: round(s, 4) for stage, s in asset.timings.items()}
    return document


def write_junit_report(result: BatchResult, path: str | os.PathLike) -> None:
    """Write ``result`` as JUnit XML, atomically: one testsuite, one testcase per asset (classname its folder,
    name its file), ``<failure>`` for an asset without a rig, ``<skipped>`` for an unchanged rigged asset."""
    import xml.etree.ElementTree as ET

    from .exchange import write_file_atomic

    failures = sum(a.failed for a in result.assets)
    skipped = sum(a.status == "skipped" and not a.failed for a in result.assets)
    attributes = {"tests": str(len(result.assets)), "failures": str(failures), "errors": "0",
                  "skipped": str(skipped), "time": f"{result.seconds:.3f}"}
    suites = ET.Element("testsuites", {"name": "autorig batch", **attributes})
    suite = ET.SubElement(suites, "testsuite", {"name": f"autorig batch {result.input_dir.name}", **attributes})
    for asset in result.assets:
        folder, _, name = asset.input.rpartition("/")
        case = ET.SubElement(suite, "testcase", {"classname": folder or ".", "name": name,
                                                 "time": f"{asset.seconds:.3f}"})
        if asset.failed:
            message = asset.error or "failed"
            if asset.status == "skipped":
                message += " (unchanged since the run that failed)"
            failure = ET.SubElement(case, "failure", {"message": message, "type": asset.error_type or "Error"})
            failure.text = message
        elif asset.status == "skipped":
            ET.SubElement(case, "skipped", {"message": "unchanged since the last run"})
        else:
            out = ET.SubElement(case, "system-out")
            out.text = f"{asset.template} -> {asset.output}" + (
                f", confidence {asset.confidence:.3f}" if asset.confidence is not None else "")
    ET.indent(suites)
    write_file_atomic(path, ET.tostring(suites, encoding="utf-8", xml_declaration=True) + b"\n")
