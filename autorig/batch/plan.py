"""What to rig: the meshes under the input folder, each with its options from the command line and the
``autorig.toml`` files above it, its output path and its resume key (see ``autorig.batch``)."""
from __future__ import annotations

import fnmatch
import hashlib
import json
import os
from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path, PurePosixPath
from typing import Iterable
from urllib.parse import unquote

from ..errors import InputError, SkeletonError, TemplateError
from ..input.limits import read_regular
from ..version import __version__

DEFAULT_EXTENSIONS = ("obj", "off", "ply", "stl", "glb", "gltf")
CONFIG_NAMES = ("autorig.toml", "autorig.json")
_CONFIG_KEYS = ("template", "skeleton", "up", "front")
_BATCH_KEYS = ("html",)  # only in the input folder's own config: the review page, relative to the output folder


class ConfigError(InputError):
    """A per-folder config file that cannot be used (exit code 2)."""


@dataclass(frozen=True)
class Plan:
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


def plan_assets(input_dir: Path, output_dir: Path, template, options, fmt: str, extensions, skeleton=None,
                skin_options=None, names: str = "template") -> list[Plan]:
    """Each asset's effective options, output path and resume key; config, template and skeleton errors raise
    here."""
    from dataclasses import replace

    from ..exchange import default_output_path
    from ..input.mesh import AxisError, frame_rotation
    from ..pipeline import SkinOptions
    from ..template import AUTO

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
    allow_outside = options.allow_outside_paths or skin_options.allow_outside_paths
    configs = _Configs(input_dir, templates, skeletons, allow_outside)

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
            settings = {"skeleton": skeletons.digest(effective["skeleton"]), "skin": {"scale": how.scale}}
        else:
            up, front = effective["up"], effective["front"]
            try:
                if "auto" not in (up, front):
                    frame_rotation(up, front)
            except AxisError as e:
                raise ConfigError(f"{input_dir / rel}: {e} (from {configs.origin_of(rel)})") from None
            loaded, parsed = templates.load(effective["template"]), None
            # A convention asked for applies to the templates that have conventions (the biped), not to the
            # others in the same folder (a quadruped); one such template without it stops the batch.
            convention = options.convention if loaded != AUTO and loaded.conventions else None
            if convention is not None:
                from ..embed.convention import convention_named
                convention_named(loaded, convention)
            sidecar = markers_sidecar(input_dir / rel) if loaded != AUTO else None
            how = replace(options, up=up, front=front, convention=convention,
                          markers=sidecar.name if sidecar is not None else None)
            label = AUTO if loaded == AUTO else loaded.name
            content = (_digest({"name": AUTO, "voxels": how.voxels, "max_segments": how.max_segments})
                       if loaded == AUTO else templates.digest(loaded))
            settings = {"template": content, "up": up, "front": front,
                        **({"convention": convention} if convention is not None else {}),
                        # --fingers only when asked (autorig.hands), so that earlier rigs still count as done
                        **({"fingers": True} if how.fingers and loaded != AUTO else {})}
        try:
            files = input_files(input_dir / rel, input_dir, allow_outside,
                                markers=getattr(how, "markers", None) is not None)
        except Exception:  # InputError, or a bug: reported as that asset's error when it is read again
            key, size = "", 0  # fails as that asset's error when it is read again to be rigged
        else:
            key = _digest({"input": {name: hashlib.sha256(data).hexdigest() for name, data in files.items()},
                           **settings, "format": fmt, "autorig": __version__,
                           # only when asked, so that rigs from before --names (and these limits) still count
                           # as done
                           **({"names": names} if names != "template" else {}), **_limits_of(how)})
            size = sum(map(len, files.values()))
        plans.append(Plan(rel, outputs[rel], loaded, parsed, how, label, up, front, key, size))
    return plans


def _limits_of(how) -> dict:
    """The input limits of ``how`` (``RigOptions`` or ``SkinOptions``) that differ from the defaults: they
    change what fails or is left out, so a resume key holds them."""
    from ..input.limits import MAX_FACES
    return {**({"max_faces": how.max_faces} if how.max_faces != MAX_FACES else {}),
            **({"allow_outside_paths": True} if how.allow_outside_paths else {})}


class _TemplateCache:
    """Template specs resolved (file templates to absolute paths), loaded and hashed once each."""

    def __init__(self):
        self._loaded: dict[str, object] = {}

    @staticmethod
    def is_file(spec: str) -> bool:
        """Whether a template spec names a file (it ends in ``.json`` or holds a path separator), not a
        built-in template."""
        return spec.endswith(".json") or os.sep in spec or "/" in spec

    @staticmethod
    def resolve(spec: str, folder: Path) -> str:
        """A built-in name (or ``auto``) stays a name; a file (``is_file``) becomes an absolute path, relative
        to ``folder``."""
        spec = str(spec)
        if _TemplateCache.is_file(spec):
            return str((folder / spec).resolve())
        return spec

    def load(self, spec: str):
        """The ``Template`` of ``spec``, or ``template.AUTO`` for "auto" (the template-free skeleton, made in the
        worker from each mesh)."""
        from ..template import AUTO, load_template
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
        from ..exchange.skeleton import read_skeleton
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

    def __init__(self, root: Path, templates: _TemplateCache, skeletons: _SkeletonCache,
                 allow_outside: bool = False):
        self.root = root
        self._allow_outside = allow_outside
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
                data = tomllib.loads(read_regular(path).decode("utf-8"))
            else:
                data = json.loads(read_regular(path).decode("utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as e:  # TOMLDecodeError and JSONDecodeError too
            raise ConfigError(f"{path}: {' '.join(str(e).split())}") from None
        except RecursionError:
            raise ConfigError(f"{path}: nests too deeply") from None
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

    def _confine(self, path: Path, key: str, name: str) -> None:
        from ..input.confine import Refused, inside
        try:
            inside(path.parent, name, self.root, self._allow_outside)
        except Refused as e:
            raise ConfigError(f"{path}: {key}: {name}: {str(e).replace('asset', 'input')}") from None

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
        for key in ("template", "skeleton"):
            # Configs are written by whoever filled the folder: the files they name stay inside it.
            if key in settings and (key == "skeleton" or _TemplateCache.is_file(settings[key])):
                self._confine(path, f"{where}{key}", settings[key])
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


def _check_axis(spec: str, key: str, where: str) -> str:
    """``spec`` in lower case if it names an axis or is ``auto``, else ``ConfigError``."""
    from ..input.mesh import AxisError, axis_vector
    if spec.lower() == "auto":
        return "auto"
    try:
        axis_vector(spec)
    except AxisError as e:
        raise ConfigError(f"{where}{key}: {e}") from None
    return spec.lower()


def markers_sidecar(path: Path) -> Path | None:
    """The markers file beside a mesh (``hero.obj`` -> ``hero.markers.json``, ``autorig.markers``), or None."""
    sidecar = path.with_name(path.stem + ".markers.json")
    return sidecar if sidecar.is_file() else None


def input_files(path: Path, root: Path | None = None, allow_outside: bool = False,
                markers: bool = False) -> dict[str, bytes]:
    """The bytes a mesh needs, by name relative to its folder: the file itself, first, with ``markers`` its
    markers file (``markers_sidecar``), and for a ``.gltf``
    the external buffers and images it names that exist (a missing one is the loader's error to report).
    Only files in the mesh's folder or below it are sent (the worker's loader says what is left out), and
    the mesh itself must lie in ``root`` (the input folder) unless ``allow_outside``: a symlink there that
    leads out of it is an ``InputError``."""
    if root is not None and not allow_outside and path.exists():  # (a dangling link: "cannot read" below)
        from ..input.confine import Refused, inside
        try:
            inside(root, os.path.relpath(path, root), root)
        except Refused:
            raise InputError(f"{path}: a symlink leads outside the input folder {root} "
                             f"(--allow-outside-paths to allow)") from None
    try:
        files = {path.name: read_regular(path, None)}
    except OSError as e:
        raise InputError(f"{path}: cannot read file ({e.strerror or e})") from None
    folder = path.parent.resolve()
    sidecar = markers_sidecar(path) if markers else None
    if sidecar is not None:   # beside the mesh, and confined as the files a mesh names are
        from ..markers import MARKERS_BYTES
        if not allow_outside and folder not in sidecar.resolve().parents:
            raise InputError(f"{sidecar}: a symlink leads outside the asset's folder (--allow-outside-paths to "
                             f"allow)")
        try:
            files[sidecar.name] = read_regular(sidecar, MARKERS_BYTES)
        except OSError as e:
            raise InputError(f"{sidecar}: cannot read file ({e.strerror or e})") from None

    def add(name: str, base: Path = folder) -> Path | None:
        try:
            target = (base / name).resolve()
            # Only files beside or below the mesh: they have to fit in a worker's scratch folder.
            if folder in target.parents and target.is_file():
                files[PurePosixPath(target.relative_to(folder).as_posix()).as_posix()] = read_regular(target)
                return target
        except (OSError, ValueError, RuntimeError):  # a NUL in the name, a symlink loop, a FIFO, too big
            pass  # not sent: the worker's loader says why it is left out
        return None

    if path.suffix.lower() == ".gltf":
        try:
            document = json.loads(files[path.name])
        except (ValueError, UnicodeDecodeError, RecursionError):
            return files  # not JSON: the loader will say so
        items = []
        for key in ("buffers", "images"):
            value = document.get(key) if isinstance(document, dict) else None
            items += value if isinstance(value, list) else []
        for item in items:
            uri = item.get("uri") if isinstance(item, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:") or ":" in uri.split("/")[0]:
                continue
            add(unquote(uri))
    elif path.suffix.lower() == ".obj":
        from ..input.look import material_files
        for library, maps in material_files(path, allow_outside):
            if add(library) is not None:
                for name in maps:
                    add(name, (folder / library).parent)
    return files


def _digest(value) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True).encode()).hexdigest()


def html_setting(input_dir: Path, output_dir: Path, allow_outside: bool = False) -> Path | None:
    """The review page that ``input_dir``'s own config asks for (``html = "review.html"``, relative to the output
    folder, and inside it unless ``allow_outside``), else None."""
    settings = _Configs(input_dir, _TemplateCache(), _SkeletonCache(input_dir), allow_outside).batch_settings()
    if "html" not in settings:
        return None
    from ..input.confine import Refused, inside
    try:  # the config is the input folder's, written by others: it may not send a page out of the output folder
        inside(output_dir, settings["html"], output_dir, allow_outside)
    except Refused as e:
        raise ConfigError(f"{input_dir}: html: {settings['html']}: {str(e).split(' (')[0].replace('asset', 'output')}"
                          ) from None
    return output_dir / settings["html"]
