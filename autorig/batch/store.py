"""What the batch keeps in its output folder: the outputs and thumbnails the workers send back, and the
manifest that lets a rerun skip what is unchanged (see Resuming in ``autorig.batch``). Every file is written
atomically (``autorig.exchange.files``)."""
from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING

from ..errors import AutorigError, OutputError
from ..version import __version__
from .result import AssetResult

if TYPE_CHECKING:
    from .plan import Plan

MANIFEST_NAME = ".autorig-batch.json"
THUMBNAILS_FOLDER = ".autorig-thumbnails"  # in the output folder: hidden, so a later batch of it skips them
_MANIFEST_VERSION = 1
MANIFEST_INTERVAL = 2.0  # seconds between manifest saves while running, so an interrupted batch resumes


def read_manifest(path: Path) -> dict:
    """{relative input: entry} from an earlier run; an absent, unreadable or foreign manifest is empty: then
    everything is rigged again, which is slow but never wrong."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.get("manifest") == _MANIFEST_VERSION and isinstance(data.get("assets"), dict):
            return data["assets"]
    except (OSError, ValueError, AttributeError):
        pass
    return {}


def write_manifest(path: Path, assets: dict) -> None:
    from ..exchange import write_file_atomic
    document = {"manifest": _MANIFEST_VERSION, "autorig": __version__, "assets": dict(sorted(assets.items()))}
    write_file_atomic(path, (json.dumps(document, indent=1) + "\n").encode())


def kept_result(plan: Plan, entry: dict | None, output_dir: Path) -> AssetResult | None:
    """The earlier outcome of ``plan`` if it still holds (same key, and the output still there), else None."""
    if not entry or entry.get("key") != plan.key or entry.get("output") != plan.output:
        return None
    if entry.get("status") == "ok" and not (output_dir / plan.output).exists():
        return None
    thumbnails = {view: rel for view, rel in (entry.get("thumbnails") or {}).items()
                  if (output_dir / rel).is_file()}
    up, front = entry.get("axes") or (plan.up, plan.front)
    return AssetResult(input=plan.rel, output=plan.output, status="skipped", previous=entry.get("status"),
                       template=plan.label, up=up, front=front, error=entry.get("error"),
                       error_type=entry.get("error_type"), confidence=entry.get("confidence"),
                       confidence_parts=entry.get("confidence_parts") or {},
                       previous_timings=entry.get("timings") or {}, thumbnails=thumbnails,
                       dropped=entry.get("dropped") or [], hands=entry.get("hands") or {},
                       rest_pose=entry.get("rest_pose"), arm_angle=entry.get("arm_angle"),
                       confidence_reasons=entry.get("confidence_reasons") or [], markers=_markers_of(plan))


def store_outcome(plan: Plan, outcome: dict, input_dir: Path, output_dir: Path, fmt: str, manifest: dict,
                  thumbnails: bool = False) -> AssetResult:
    """Write a finished asset's output (and with ``thumbnails`` its pictures), remember its outcome when it
    would come out the same again, and return its ``AssetResult``."""
    up, front = outcome.get("axes") or (plan.up, plan.front)   # the axes found, not "auto"
    result = AssetResult(input=plan.rel, output=plan.output, status=outcome["status"],
                         template=plan.label, up=up, front=front, error=outcome.get("error"),
                         error_type=outcome.get("error_type"), confidence=outcome.get("confidence"),
                         confidence_parts=outcome.get("confidence_parts", {}),
                         seconds=outcome.get("seconds", 0.0), timings=outcome.get("timings", {}),
                         dropped=outcome.get("dropped", []), hands=outcome.get("hands", {}),
                         rest_pose=outcome.get("rest_pose"), arm_angle=outcome.get("arm_angle"),
                         confidence_reasons=outcome.get("confidence_reasons", []), markers=_markers_of(plan))
    out = output_dir / plan.output
    _remove_thumbnails(output_dir, plan.output)  # of an earlier rig: the new one (or none) replaces them
    if result.status == "ok":
        try:
            _write_output(out, outcome["data"], fmt, input_dir / plan.rel, output_dir)
            if thumbnails:
                result.thumbnails = _write_thumbnails(output_dir, plan.output, outcome.get("thumbnails", {}))
        except AutorigError as e:
            result.status, result.error, result.error_type = "failed", str(e), type(e).__name__
            result.confidence, result.confidence_parts, result.confidence_reasons = None, {}, []
            result.rest_pose = result.arm_angle = None
            outcome = {"remember": False}
    elif plan.rel in manifest and manifest[plan.rel].get("status") == "ok":
        _remove_output(out, fmt)
    if outcome.get("remember"):
        manifest[plan.rel] = {"key": plan.key, "output": plan.output, "status": result.status,
                              "error": result.error, "error_type": result.error_type,
                              "confidence": result.confidence, "seconds": round(result.seconds, 3),
                              "confidence_parts": result.confidence_parts,
                              **({"confidence_reasons": result.confidence_reasons}
                                 if result.confidence_reasons else {}),
                              "timings": {stage: round(s, 4) for stage, s in result.timings.items()},
                              "thumbnails": result.thumbnails,
                              **({"axes": [result.up, result.front]} if outcome.get("axes") else {}),
                              **({"dropped": result.dropped} if result.dropped else {}),
                              **({"hands": result.hands} if result.hands else {}),
                              **({"rest_pose": result.rest_pose, "arm_angle": result.arm_angle}
                                 if result.rest_pose else {})}
    else:
        manifest.pop(plan.rel, None)
    return result


def _markers_of(plan: Plan) -> str | None:
    """The markers file an asset is rigged with, relative to the input folder, or None."""
    name = getattr(plan.options, "markers", None)
    return None if name is None else str(PurePosixPath(plan.rel).with_name(name))


def _write_output(out: Path, data: bytes | dict[str, bytes], fmt: str, source: Path, output_dir: Path) -> None:
    """Write a worker's output bytes (a file's, or {name: bytes} of a Pinocchio folder) to ``out``."""
    from ..exchange import check_output, write_file_atomic, write_folder_atomic
    make_parent(out, output_dir)
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
    from ..exchange import write_file_atomic
    written = {}
    for view, data in pictures.items():
        rel = _thumbnail_path(output, view)
        make_parent(output_dir / rel, output_dir)
        write_file_atomic(output_dir / rel, data)
        written[view] = rel
    return written


def _remove_thumbnails(output_dir: Path, output: str) -> None:
    for view in ("front", "side", "top"):     # the views render_thumbnails draws (top: a flat shape)
        with contextlib.suppress(OSError):
            (output_dir / _thumbnail_path(output, view)).unlink()


def _remove_output(out: Path, fmt: str) -> None:
    """Delete an output this batch wrote earlier (the manifest says so) for an input that now fails."""
    from ..exchange.pinocchio import FILES
    with contextlib.suppress(OSError):
        if fmt == "pinocchio" and out.is_dir() and not out.is_symlink():
            for name in FILES:
                with contextlib.suppress(FileNotFoundError):
                    (out / name).unlink()
            out.rmdir()
        elif out.is_file():
            out.unlink()


def check_writable(path: Path, output_dir: Path) -> None:
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


def make_parent(path: Path, root: Path | None = None) -> None:
    """Make the folders ``path`` lies in. Below ``root`` (the output folder), a symlink where a folder goes is
    replaced by a real folder, so that nothing is written through it to where it points."""
    try:
        if root is not None and _within(path, root):
            folder = Path(root)
            for part in path.parent.relative_to(root).parts:
                folder = folder / part
                if folder.is_symlink():
                    folder.unlink()
                folder.mkdir(exist_ok=True)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
    except (OSError, ValueError) as e:
        raise OutputError(f"cannot write {path}: {getattr(e, 'strerror', None) or e}") from None


def _within(path: Path, root: Path) -> bool:
    try:
        Path(os.path.abspath(path)).relative_to(os.path.abspath(root))
        return True
    except ValueError:
        return False
