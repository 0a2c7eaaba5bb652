"""Mesh input: read a file, check that it is a usable surface, and put it in autorig's canonical frame.

The canonical frame, shared by every stage (and by the templates, see ``template.py``):

* +y is up, +z is the way the character faces, +x is the character's own left (left = up x front, so the
  frame is right-handed and the change of frame is a proper rotation);
* the feet (the lowest point along up) are at y = 0 and the bounding box is centred on x and z (the rig then
  moves x = 0 to the body's mid-plane, ``orient.mid_plane``, since a prop held to one side moves the box);
* the height (the extent along up) is 1.

``load_mesh`` (its readers in ``mesh_files``) keeps the file's vertices exactly, in file order, because the rig's
skin weights are written per input vertex. ``prepare`` adds the canonical frame and a cleaned working copy for the
geometric stages.

Every problem with the input raises ``InputError`` with one line naming the file (or "mesh") and the problem.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import AutorigError, InputError
from .facing import face_cross, outward, used_vertices
from .limits import MAX_FACES, check_faces, check_file_size, read_regular
from .mesh_files import FORMATS, as_text, check_header, load_with_trimesh, parse_obj, parse_off
from .working import working_copy

# A mesh whose points all lie within this fraction of its size from one plane is a 2D cut-out.
FLAT_TOLERANCE = 1e-6
# Triangles smaller than this (in units of size squared) carry no usable geometry: their angles, normals and
# cotangent weights are numerically meaningless.
AREA_TOLERANCE = 1e-12
# The discretization reads a working mesh of up to FULL_FACES triangles as it is, and a denser one simplified
# to COARSE_FACES. Quadric decimation retessellates the whole copy when any coordinate moves (a re-export's
# float rounding moved all of the ogre's spheres and a joint by 8 % of the height): game characters and most
# scans are read whole, so that they get the same rig after a re-export; a denser scan is simplified for speed.
FULL_FACES = 150_000
COARSE_FACES = 6_000


class AxisError(AutorigError, ValueError):
    """A bad ``up``/``front`` axis spec, or up parallel to front. Exit code 2, like a command-line usage error."""
    exit_code = 2


# ----------------------------------------------------------------------------------------------------- loading

def load_mesh(path: str | Path, max_faces: int | None = MAX_FACES, allow_outside: bool = False
              ) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh from an OBJ, OFF, PLY, STL, glTF or GLB file.

    Returns ``(vertices, faces)``:

    vertices  [V, 3] float64, the file's vertices in file order. Nothing is merged, reordered or dropped
              (unreferenced vertices are kept); STL has no shared vertices, so there V = 3F, the triangle corners
              in file order.
    faces     [F, 3] int64 triangles indexing ``vertices``. Polygons are fan-triangulated: (a, b, c, d) becomes
              (a, b, c), (a, c, d). OBJ and OFF keep the file's face order; trimesh's PLY reader groups
              triangulated polygons by their number of sides.

    A glTF scene is flattened: each mesh node's vertices are moved by the node's world transform, and the nodes
    are concatenated in order of their node names (see ``autorig.exchange.gltf.read_gltf_scene``). Point clouds
    and lines in a scene are ignored. Materials and textures are not read here (``autorig.input.look`` does).

    Raises ``InputError`` (one line naming the file) for a missing or unreadable file, an unknown format,
    content that is not a mesh, and for meshes that cannot be rigged (see ``check_mesh``); also, before
    anything is allocated for them, for counts the file declares but does not hold, for more than
    ``max_faces`` triangles (None: no limit) and for a mesh too big for the memory available
    (``autorig.input.limits``). A glTF's buffer files must lie in its folder unless ``allow_outside``
    (``autorig.input.confine``).
    """
    path = check_mesh_path(path)
    suffix = path.suffix.lower()
    check_file_size(path)
    if suffix in (".obj", ".off"):
        vertices, faces = parse_mesh_bytes(read_file(path), path, max_faces)
    elif suffix in (".glb", ".gltf"):
        from ..exchange.gltf import read_gltf_scene
        vertices, faces, _ = read_gltf_scene(path, allow_outside, max_faces, look=False)
    else:
        check_header(path, suffix, max_faces)
        vertices, faces = load_with_trimesh(path, suffix)
    check_faces(len(faces), max_faces, str(path))
    return check_mesh(vertices, faces, name=str(path))


def read_file(path: Path) -> bytes:
    """The bytes of the mesh file ``path``; ``InputError`` if it cannot be read."""
    try:
        return read_regular(path, None)
    except OSError as e:
        raise InputError(f"{path}: cannot read file ({e.strerror or e})") from None


def parse_mesh_bytes(data: bytes, path: Path, max_faces: int | None) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of an OBJ or OFF file's bytes ``data`` (``path`` names the file and its format), not
    yet checked by ``check_mesh``."""
    suffix = path.suffix.lower()
    if suffix == ".obj":  # every polygon line is one triangle or more
        check_faces(data.count(b"\nf ") + data.startswith(b"f "), max_faces, str(path))
    text = as_text(data, path, FORMATS[suffix])
    try:
        return parse_obj(text, path) if suffix == ".obj" else parse_off(text, path, max_faces)
    except OverflowError:  # "f 1 2 99999999999999999999999"
        raise InputError(f"{path}: a face index too large for any mesh") from None


def check_mesh_path(path: str | Path) -> Path:
    """``path`` as a Path, if it names an existing file in a format ``load_mesh`` reads; else ``InputError``.
    Cheap (no reading), so a command line can reject a mistyped path before any slow work."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, not a mesh file")
    if not path.is_file():  # a FIFO would block its reader for ever, a device never end
        raise InputError(f"{path}: not a regular file (a FIFO, device or socket), not a mesh file")
    if path.suffix.lower() not in FORMATS:
        known = ", ".join(sorted(FORMATS))
        raise InputError(f"{path}: unknown mesh format {path.suffix or '(no extension)'!r}; autorig reads {known}")
    return path


# -------------------------------------------------------------------------------------------------- validation

def check_mesh(vertices, faces, name: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    """Check that ``vertices`` [V, 3] and ``faces`` [F, 3] describe a surface that can be rigged.

    Returns the same data as a float64 [V, 3] and an int64 [F, 3] array (copies; the arguments are never
    modified). Raises ``InputError`` with one line starting with ``name`` for: wrong shapes or types, no
    vertices, no faces (a point cloud), NaN or infinite coordinates, face indices out of range, fewer than four
    distinct vertices in the triangles, zero size, only zero-area triangles, and flat (2D) meshes.
    The geometric checks look only at the vertices that the triangles use: stray vertices do not count.
    """
    def bad(problem: str) -> InputError:
        return InputError(f"{name}: {problem}")

    try:
        V = np.array(vertices, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise bad("vertices must be an [V, 3] array of numbers") from None
    if V.size == 0:
        raise bad("contains no vertices (empty mesh)")
    if V.ndim != 2 or V.shape[1] != 3:
        raise bad(f"vertices must be an [V, 3] array of numbers, got shape {V.shape}")
    try:
        F = np.array(faces)
    except (TypeError, ValueError, OverflowError):
        F = np.array(None)
    if F.size == 0:
        raise bad(f"has {len(V)} vertices but no faces: a point cloud, not a surface mesh")
    if F.dtype.kind == "f" and np.all(np.isfinite(F)) and np.all(F == np.round(F)) and np.all(abs(F) < 2**62):
        F = F.astype(np.int64)  # e.g. indices that went through JSON or a float array
    if F.dtype.kind not in "iu" or (F.dtype.kind == "u" and F.size and F.max() > 2**62):
        raise bad("faces must be an [F, 3] array of integer vertex indices")
    F = F.astype(np.int64)
    if F.ndim != 2 or F.shape[1] != 3:
        raise bad(f"faces must be an [F, 3] array of vertex indices (triangles), got shape {F.shape}")

    finite = np.isfinite(V).all(axis=1)
    if not finite.all():
        first = int(np.argmin(finite))
        raise bad(f"{int((~finite).sum())} vertices have NaN or infinite coordinates (the first is vertex {first})")
    outside = (F < 0) | (F >= len(V))
    if outside.any():
        face = int(np.argmax(outside.any(axis=1)))
        raise bad(f"face indices out of range: face {face} uses vertex {int(F[outside][0])}, "
                  f"but there are only {len(V)} vertices")
    _check_solid(V, F, bad)
    return V, F


def _check_solid(V: np.ndarray, F: np.ndarray, bad) -> None:
    """Raise ``bad(...)`` unless the triangles F [F, 3] over V [V, 3] span a volume: at least four vertices,
    non-zero size, some triangles with area, and not all within FLAT_TOLERANCE x size of one plane."""
    used, renumber = used_vertices(len(V), F)
    if len(used) < 4:
        raise bad(f"only {len(used)} distinct vertices in its {len(F)} triangle(s); a mesh needs at least 4 "
                  f"vertices around a volume")
    P = V[used]
    lo, hi = P.min(axis=0), P.max(axis=0)
    with np.errstate(over="ignore", invalid="ignore"):
        size = float(np.max(hi - lo))
    if not np.isfinite(size):
        raise bad("coordinates too large to work with")
    if size == 0:
        raise bad("zero size: all its vertices are at one point")
    # Work in units of the mesh size from here on, so the tolerances are relative and nothing overflows.
    Q = (P - (lo / 2 + hi / 2)) / size
    local = renumber[F]
    area = 0.5 * np.linalg.norm(face_cross(Q, local), axis=1)
    good = area > AREA_TOLERANCE
    if not good.any():
        raise bad("every triangle has zero area")
    R = Q[used_vertices(len(Q), local[good])[0]]
    centred = R - R.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    spread = np.ptp(centred @ axes.T, axis=0)  # extent along the principal axes, largest first
    if spread[1] <= FLAT_TOLERANCE:
        raise bad("all its vertices lie on one line: autorig needs a 3D surface that encloses a volume")
    if spread[2] <= FLAT_TOLERANCE:
        raise bad("the mesh is flat (all its vertices lie in one plane, like a 2D cut-out); autorig needs a "
                  "3D surface that encloses a volume")


# ----------------------------------------------------------------------------------------------- canonical frame

_AXES = {"x": 0, "y": 1, "z": 2}


def axis_vector(spec: str) -> np.ndarray:
    """Unit vector [3] for an axis spec: 'x', 'y', 'z', optionally signed ('-x', '+y'). Raises ``AxisError``."""
    text = str(spec).strip().lower()
    sign = -1.0 if text.startswith("-") else 1.0
    letter = text[1:] if text[:1] in "+-" else text
    if letter not in _AXES or not text:
        raise AxisError(f"bad axis {spec!r}: use x, y, z, -x, -y or -z")
    vector = np.zeros(3)
    vector[_AXES[letter]] = sign
    return vector


def frame_rotation(up: str = "y", front: str = "z") -> np.ndarray:
    """Rotation [3, 3] whose rows are the input-space directions of canonical x (left), y (up) and z (front)."""
    u, f = axis_vector(up), axis_vector(front)
    if abs(float(u @ f)) > 0.5:
        raise AxisError(f"up {up!r} and front {front!r} are parallel; the front must be perpendicular to up")
    return np.array([np.cross(u, f), u, f])


@dataclass
class PreparedMesh:
    """A checked mesh in the canonical frame, plus a cleaned working copy.

    vertices       [V, 3] float64 all input vertices, in input order, in the canonical frame
    faces          [F, 3] int64 the input triangles (indices into ``vertices``)
    work_vertices  [W, 3] float64 canonical positions of the working mesh: coincident input vertices merged,
                   vertices no remaining triangle uses dropped; ordered by the first input vertex of each
    work_faces     [G, 3] int64 working triangles (indices into ``work_vertices``): zero-area triangles and
                   repeated triangles (same three vertices, either orientation) dropped, input order otherwise;
                   connected pieces that faced inward turned outward
    work_index     [V] int64 for each input vertex, the working vertex at its position, or -1 if no working
                   triangle touches that position (unreferenced or only in dropped triangles)
    rotation       [3, 3] rows are the input-space directions of canonical x (left), y (up), z (front)
    offset         [3] the input-space point that maps to the canonical origin (centre of the feet)
    scale          canonical units per input unit (1 / height)
    up, front      the axis specs used
    height         the mesh's extent along up, in input units

    canonical = scale * rotation @ (p - offset)
    """
    vertices: np.ndarray
    faces: np.ndarray
    work_vertices: np.ndarray
    work_faces: np.ndarray
    work_index: np.ndarray
    rotation: np.ndarray
    offset: np.ndarray
    scale: float
    up: str
    front: str
    height: float

    @property
    def matrix(self) -> np.ndarray:
        """[4, 4] homogeneous transform from input to canonical coordinates."""
        M = np.eye(4)
        M[:3, :3] = self.scale * self.rotation
        M[:3, 3] = -self.scale * self.rotation @ self.offset
        return M

    def to_canonical(self, points) -> np.ndarray:
        """Input-space points [N, 3] (or one point [3]) -> canonical [N, 3] (or [3])."""
        return self.scale * ((np.asarray(points, dtype=np.float64) - self.offset) @ self.rotation.T)

    def from_canonical(self, points) -> np.ndarray:
        """Canonical points [N, 3] (or one point [3]) -> input space [N, 3] (or [3])."""
        return (np.asarray(points, dtype=np.float64) / self.scale) @ self.rotation + self.offset

    def reframed(self, up: str, front: str) -> "PreparedMesh":
        """The same mesh in the canonical frame of other axes (no new checks, no new working copy)."""
        moved = self._in_frame(up, front)
        change = moved.change_from(self)
        moved.vertices = change.apply(self.vertices)
        moved.work_vertices = change.apply(self.work_vertices)
        return moved

    def centred_at(self, x: float) -> "PreparedMesh":
        """The same mesh and axes with the canonical origin moved along x to ``x`` (canonical units): the
        frame centred on the body's mid-plane rather than its bounding box (``orient.mid_plane``). Itself
        for x = 0."""
        if x == 0.0:
            return self
        shift = np.array([float(x), 0.0, 0.0])
        return replace(self, vertices=self.vertices - shift, work_vertices=self.work_vertices - shift,
                       offset=self.offset + self.rotation.T @ shift / self.scale)

    def frame_change(self, up: str, front: str) -> "FrameChange":
        """The map from this canonical frame to that of other axes, without moving any vertex."""
        return self._in_frame(up, front).change_from(self)

    def _in_frame(self, up: str, front: str) -> "PreparedMesh":
        """A PreparedMesh with the frame of (up, front) whose vertex arrays are still this one's."""
        rotation = frame_rotation(up, front)
        # Frames differ by signed axis permutations, which map the working mesh's bounding box onto the new
        # one exactly: its 8 corners give the new box without rotating every vertex (orientation detection
        # asks for 8 frames: 0.45 s on a 200k-face scan).
        lo, hi = column_min(self.work_vertices), column_max(self.work_vertices)
        corners = np.where(np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], bool), hi, lo)
        rotated = self.from_canonical(corners) @ rotation.T
        lo, hi = rotated.min(axis=0), rotated.max(axis=0)
        height = float(hi[1] - lo[1])
        offset = rotation.T @ np.array([lo[0] / 2 + hi[0] / 2, lo[1], lo[2] / 2 + hi[2] / 2])
        return PreparedMesh(vertices=self.vertices, faces=self.faces, work_vertices=self.work_vertices,
                            work_faces=self.work_faces, work_index=self.work_index, rotation=rotation,
                            offset=offset, scale=1.0 / height, up=up, front=front, height=height)

    def change_from(self, other: "PreparedMesh") -> "FrameChange":
        """The map from ``other``'s canonical frame to this one's."""
        rotation = self.rotation @ other.rotation.T
        ratio = self.scale / other.scale
        return FrameChange(rotation, ratio, -self.scale * self.rotation @ self.offset
                           + ratio * rotation @ (other.scale * other.rotation @ other.offset))

    def coarse(self, max_faces: int = COARSE_FACES, whole: int = FULL_FACES) -> tuple[np.ndarray, np.ndarray]:
        """The working mesh as it is when it has at most ``whole`` triangles, else simplified to at most
        ``max_faces``: (vertices [W', 3], faces [G', 3]) in the canonical frame. Dense scans carry far more
        triangles than the skeleton's discretization can use; quadric decimation (fast-simplification) keeps
        the shape, but its result jumps when the mesh moves by a rounding error, and the rig with it."""
        if len(self.work_faces) <= max(max_faces, whole):
            return self.work_vertices, self.work_faces
        import fast_simplification
        vertices, faces = fast_simplification.simplify(self.work_vertices, self.work_faces.astype(np.int32),
                                                       target_count=max_faces)
        return np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)


@dataclass(frozen=True)
class FrameChange:
    """new = scale * rotation @ old + offset, between two canonical frames of one mesh."""
    rotation: np.ndarray
    scale: float
    offset: np.ndarray

    def apply(self, points) -> np.ndarray:
        return self.scale * (np.asarray(points, dtype=np.float64) @ self.rotation.T) + self.offset


def prepare(vertices, faces, up: str = "y", front: str = "z", name: str = "mesh", *,
            checked: bool = False, unit: str | None = None) -> PreparedMesh:
    """Check a mesh and bring it into the canonical frame (see the module docstring).

    vertices  [V, 3] input vertex positions
    faces     [F, 3] input triangles
    up, front the input-space axes ('x', '-z', ...) that point up and the way the character faces
    name      how error messages refer to the mesh (e.g. its file name)
    checked   the arrays are ``check_mesh``'s (or ``load_mesh``'s) output: not checked again
    unit      the input axis whose extent is the frame's unit of length (default: ``up``, the height); the rig
              discretizes in the input's own axes but in units of the height the user gave, so that turning
              a Z-up mesh about its up axis does not rescale its distance field

    The feet, centring and height come from the bounding box of the vertices the triangles use, so stray
    unreferenced vertices do not move the frame. Raises ``InputError`` (see ``check_mesh``) or ``AxisError``.
    """
    rotation = frame_rotation(up, front)
    # The pipeline's meshes come from load_mesh or check_mesh already: a second check costs 0.1 s per 200k faces.
    V, F = (vertices, faces) if checked else check_mesh(vertices, faces, name)
    used, _ = used_vertices(len(V), F)
    rotated = V[used] @ rotation.T  # exact: the rotation only permutes and negates coordinates
    lo, hi = rotated.min(axis=0), rotated.max(axis=0)
    height = float(hi[1] - lo[1])
    centre = np.array([lo[0] / 2 + hi[0] / 2, lo[1], lo[2] / 2 + hi[2] / 2])
    offset = rotation.T @ centre
    scale = 1.0 / height
    if unit is not None and unit.lstrip("+-") != up.lstrip("+-"):
        along = V[used] @ frame_rotation(unit, "z" if unit.lstrip("+-") != "z" else "x")[1]
        height = float(along.max() - along.min())
        scale = 1.0 / height
    with np.errstate(over="ignore", invalid="ignore"):
        canonical = scale * ((V - offset) @ rotation.T)
    if not np.isfinite(scale) or not np.isfinite(canonical).all():
        raise InputError(f"{name}: vertex coordinates span too large a range to work with")

    work_vertices, work_faces, work_index = working_copy(V, F, canonical, AREA_TOLERANCE)
    if not len(work_faces):     # a body welded to nothing: a stray vertex a hundred thousand heights away
        raise InputError(f"{name}: after merging coincident vertices and dropping degenerate triangles, no "
                         f"triangle is left (is one vertex far away from the rest?)")
    work_faces = outward(work_vertices, work_faces)
    _check_solid(work_vertices, work_faces,
                 lambda problem: InputError(f"{name}: after merging coincident vertices and dropping "
                                            f"degenerate triangles, {problem}"))
    # Decimation of very large meshes belongs here: simplify (work_vertices, work_faces) and compose the
    # vertex map into work_index, so later stages never see more than a bounded number of vertices.
    return PreparedMesh(vertices=canonical, faces=F, work_vertices=work_vertices, work_faces=work_faces,
                        work_index=work_index, rotation=rotation, offset=offset, scale=scale,
                        up=up, front=front, height=height)


def spread(points: np.ndarray, count: int) -> np.ndarray:
    """Indices of about ``count`` of ``points`` [N, 3] spread over their extent, chosen by where the points
    are and not by their order: the point nearest the centre of each occupied cell of a grid centred on the
    points' box (about ``count`` cells occupied). Taking every k-th point instead picks other points when a
    file lists its vertices in another order, and turns a mesh's measured symmetry, and the rig, with it; this
    choice is the same for any order, for the mesh turned or mirrored about its box's centre, and moves by
    one point of a cell when a rounding error carries a point across the cell's middle."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) <= count:
        return np.arange(len(points))
    lo, hi = column_min(points), column_max(points)
    centre = (lo + hi) / 2
    size = float(np.linalg.norm(hi - lo)) / np.sqrt(count) or 1.0

    def cells(size: float):
        key = np.floor((points - centre) / size + 0.5).astype(np.int64)
        # The cells numbered in the order of their integer coordinates (x, then y, then z), as np.unique(key,
        # axis=0) numbers them, through one integer per point: sorting rows is ~10 times slower.
        shifted = key - column_min(key)
        span = column_max(shifted) + 1
        _, cell = np.unique((shifted[:, 0] * span[1] + shifted[:, 1]) * span[2] + shifted[:, 2],
                            return_inverse=True)
        return key, cell.reshape(-1)

    key, cell = cells(size)
    size *= np.sqrt((cell.max() + 1) / count)     # occupied cells go as the surface's area over size squared
    key, cell = cells(size)
    off = np.linalg.norm(points - (centre + key * size), axis=1)
    # nearest first within each cell; exact ties (a symmetric mesh's mirror pair) by position. Only the points
    # as near as their cell's nearest can win, so only they are sorted.
    nearest = np.full(cell.max() + 1, np.inf)
    np.minimum.at(nearest, cell, off)
    tied = np.flatnonzero(off == nearest[cell])
    order = tied[np.lexsort((points[tied, 2], points[tied, 1], points[tied, 0], cell[tied]))]
    first = order[np.r_[True, cell[order][1:] != cell[order][:-1]]]
    return np.sort(first)


def column_min(array: np.ndarray) -> np.ndarray:
    """``array.min(axis=0)`` of an [N, K] array with few columns, column by column: numpy reduces a C-order
    [N, 3] array along its rows some 8 times slower (1.6 ms against 0.2 ms at 86k rows)."""
    return np.array([array[:, k].min() for k in range(array.shape[1])], dtype=array.dtype)


def column_max(array: np.ndarray) -> np.ndarray:
    """``array.max(axis=0)``, column by column (see ``column_min``)."""
    return np.array([array[:, k].max() for k in range(array.shape[1])], dtype=array.dtype)
