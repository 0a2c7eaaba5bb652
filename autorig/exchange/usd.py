"""UsdSkel output through Pixar's ``usd-core`` (``pip install 'autorig[usd]'``): ``.usda`` (text), ``.usdc``
(binary) or ``.usdz`` (one zip package holding the layer and its textures).

What is written:

- ``/Rig``, the default prim: a ``SkelRoot``; the stage's ``upAxis`` is Y and ``metersPerUnit`` 1 (the input's
  units taken as metres, as glTF does);
- ``/Rig/Skeleton``: the joints (paths such as ``hips/spine/chest``, ``:`` in a name written as ``_``),
  ``bindTransforms`` (each joint's world transform in the rest pose) and ``restTransforms`` (the same,
  relative to the parent joint);
- one ``Mesh`` per part of the input (``Look.parts``; a bare mesh is one part), with points, triangles,
  normals, UVs (``primvars:st``, ``st1``, ...; USD's v grows upwards), vertex colours (``displayColor``),
  bound to the skeleton by ``UsdSkelBindingAPI`` with the same 4 strongest influences per vertex as the glTF
  (``primvars:skel:jointIndices``/``jointWeights``, elementSize 4);
- ``/Rig/Materials``: one ``UsdPreviewSurface`` material per input material, its base colour (and normal,
  emission) textures read through ``UsdUVTexture`` and ``st``; a part with several materials gets one
  ``GeomSubset`` per material. Textures are the input's image files, bytes untouched: inside the package for
  ``.usdz``, else in a folder beside the layer (``hero.usda`` -> ``hero_textures/``).
"""
from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

import numpy as np

from ..errors import OutputError, missing_package
from ..result import Rig
from .arrays import check_rig
from .files import write_file_atomic

__all__ = ["write_usd", "require_usd", "SUFFIXES", "usd_joint_paths"]

SUFFIXES = (".usda", ".usdc", ".usdz")
_WRAP = {33071: "clamp", 33648: "mirror", 10497: "repeat"}


def _pxr():
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, UsdSkel, Vt
    except ImportError:
        raise missing_package("USD output", "usd-core", "usd") from None
    return Gf, Sdf, Usd, UsdGeom, UsdShade, UsdSkel, Vt


def require_usd() -> None:
    """Raise ``MissingPackageError`` (exit 9) saying what to install if usd-core is missing."""
    _pxr()


def write_usd(rig: Rig, path: str | os.PathLike, kind: str | None = None) -> None:
    """Write ``rig`` as UsdSkel to ``path``, atomically; ``OutputError`` on failure. ``kind`` is usda, usdc or
    usdz (default: from the path's extension)."""
    path = Path(path)
    suffix = "." + kind if kind else path.suffix.lower()
    if suffix not in SUFFIXES:
        raise OutputError(f"cannot write {path}: USD output ends in {', '.join(SUFFIXES)}")
    _pxr()
    check_rig(rig)
    with tempfile.TemporaryDirectory(prefix=".autorig-usd-", dir=path.parent) as scratch:
        scratch = Path(scratch)
        texture_folder = path.stem + "_textures"
        images = _image_files(rig, texture_folder)
        layer = scratch / ("rig.usdc" if suffix == ".usdz" else "rig" + suffix)
        stage = _stage(rig, images)  # kept in a variable: the layer lives only as long as its stage
        stage.GetRootLayer().Export(str(layer))
        if suffix == ".usdz":
            from pxr import Sdf
            package = scratch / "rig.usdz"
            writer = Sdf.ZipFileWriter.CreateNew(str(package))
            writer.AddFile(str(layer), "rig.usdc")
            for name, data in images.items():
                (scratch / name).parent.mkdir(parents=True, exist_ok=True)
                (scratch / name).write_bytes(data)
                writer.AddFile(str(scratch / name), name)
            writer.Save()
            write_file_atomic(path, package.read_bytes())
            return
        if images:
            if (path.parent / texture_folder).is_symlink():  # replaced, never written through
                (path.parent / texture_folder).unlink()
            (path.parent / texture_folder).mkdir(exist_ok=True)
        for name, data in images.items():
            write_file_atomic(path.parent / name, data)
        write_file_atomic(path, layer.read_bytes())


def usd_joint_paths(names: list[str], parents: np.ndarray) -> list[str]:
    """UsdSkel joint paths: each joint's name (made a valid prim name) after its ancestors', ``/``-joined."""
    safe = [re.sub(r"[^A-Za-z0-9_]", "_", name) or "joint" for name in names]
    safe = [("_" + s) if s[0].isdigit() else s for s in safe]
    paths: list[str] = []
    for j, p in enumerate(parents):
        paths.append(safe[j] if p < 0 else paths[p] + "/" + safe[j])
    return paths


def _image_files(rig: Rig, folder: str) -> dict[str, bytes]:
    """{path relative to the layer: bytes} of the rig's texture images."""
    if rig.look is None:
        return {}
    files = {}
    for k, image in enumerate(rig.look.images):
        extension = {"image/png": ".png", "image/jpeg": ".jpg"}.get(image.mime_type, ".bin")
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", image.name) or "image"
        files[f"{folder}/{k}_{stem}{extension}"] = image.data
    return files


def _bind_matrices(rig: Rig) -> np.ndarray:
    """[J, 4, 4] each joint's world transform at rest (column vectors)."""
    if rig.joint_nodes is not None:
        return np.linalg.inv(np.asarray(rig.joint_nodes.inverse_bind, dtype=np.float64))
    bind = np.tile(np.eye(4), (len(rig.names), 1, 1))
    bind[:, :3, 3] = rig.joints
    return bind


def _stage(rig: Rig, images: dict[str, bytes]):
    Gf, Sdf, Usd, UsdGeom, UsdShade, UsdSkel, Vt = _pxr()
    from .gltf import top4_influences, vertex_normals

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    root = UsdSkel.Root.Define(stage, "/Rig")
    stage.SetDefaultPrim(root.GetPrim())

    parents = np.asarray(rig.parents)
    bind = _bind_matrices(rig)
    rest = np.array([bind[j] if p < 0 else np.linalg.inv(bind[p]) @ bind[j] for j, p in enumerate(parents)])
    skeleton = UsdSkel.Skeleton.Define(stage, "/Rig/Skeleton")
    skeleton.CreateJointsAttr(Vt.TokenArray(usd_joint_paths(rig.names, parents)))
    skeleton.CreateJointNamesAttr(Vt.TokenArray([str(n) for n in rig.names]))
    # Gf matrices act on row vectors: store each transpose.
    skeleton.CreateBindTransformsAttr(Vt.Matrix4dArray([Gf.Matrix4d(m.T.tolist()) for m in bind]))
    skeleton.CreateRestTransformsAttr(Vt.Matrix4dArray([Gf.Matrix4d(m.T.tolist()) for m in rest]))

    look = rig.look
    vertices = np.asarray(rig.vertices, dtype=np.float64)
    slots, amounts = top4_influences(rig.weights)
    normals = vertex_normals(vertices, np.asarray(rig.faces))
    if look is None:
        copy, faces = np.arange(len(vertices)), np.asarray(rig.faces)
        face_part, face_material, parts = np.zeros(len(faces), dtype=np.int64), np.full(len(faces), -1), [
            {"name": "mesh"}]
    else:
        copy, faces = np.asarray(look.vertex_of), np.asarray(look.faces)
        face_part, face_material, parts = look.face_part, look.face_material, look.parts
    materials = _materials(stage, rig, images) if look is not None else []
    used_names: set[str] = {"Skeleton", "Materials"}
    for p, part in enumerate(parts):
        in_part = np.flatnonzero(face_part == p)
        if not len(in_part):
            continue
        used, local = np.unique(faces[in_part], return_inverse=True)
        name = _unique(re.sub(r"[^A-Za-z0-9_]", "_", part["name"]) or "mesh", used_names)
        mesh = UsdGeom.Mesh.Define(stage, f"/Rig/{name}")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(vertices[copy[used]].astype(np.float32)))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(in_part), 3, dtype=np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(local.reshape(-1).astype(np.int32)))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        # USD's default orientation is right-handed (counter-clockwise front faces), as glTF's.
        own = look.normals if look is not None and look.normals is not None else None
        mesh.CreateNormalsAttr(Vt.Vec3fArray.FromNumpy(
            (np.asarray(own)[used] if own is not None else normals[copy[used]]).astype(np.float32)))
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
        box = vertices[copy[used]]
        mesh.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.array([box.min(axis=0), box.max(axis=0)],
                                                               dtype=np.float32)))
        primvars = UsdGeom.PrimvarsAPI(mesh)
        if look is not None:
            for k, uv in enumerate(look.texcoords):
                st = np.asarray(uv, dtype=np.float32)[used].copy()
                st[:, 1] = 1.0 - st[:, 1]  # glTF's v runs down the image, USD's up
                primvars.CreatePrimvar("st" if k == 0 else f"st{k}", Sdf.ValueTypeNames.TexCoord2fArray,
                                       UsdGeom.Tokens.vertex).Set(Vt.Vec2fArray.FromNumpy(st))
            if look.colors is not None:
                mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(
                    Vt.Vec3fArray.FromNumpy(np.asarray(look.colors, dtype=np.float32)[used, :3]))
        binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
        binding.CreateSkeletonRel().SetTargets([skeleton.GetPath()])
        binding.CreateJointIndicesPrimvar(False, 4).Set(
            Vt.IntArray.FromNumpy(slots[copy[used]].reshape(-1).astype(np.int32)))
        binding.CreateJointWeightsPrimvar(False, 4).Set(
            Vt.FloatArray.FromNumpy(amounts[copy[used]].reshape(-1).astype(np.float32)))
        binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))
        _bind_materials(stage, mesh, face_material[in_part], materials, UsdGeom, UsdShade)
    return stage


def _unique(name: str, used: set[str]) -> str:
    candidate, k = name if not name[0].isdigit() else "_" + name, 1
    base = candidate
    while candidate in used:
        candidate, k = f"{base}_{k}", k + 1
    used.add(candidate)
    return candidate


def _bind_materials(stage, mesh, face_material: np.ndarray, materials: list, UsdGeom, UsdShade) -> None:
    """Bind the triangles' materials: the whole mesh when it has one, else one GeomSubset per material."""
    present = [int(m) for m in np.unique(face_material) if m >= 0]
    if not present:
        return
    if len(present) == 1 and (face_material == present[0]).all():
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(materials[present[0]])
        return
    for m in present:
        subset = UsdGeom.Subset.CreateGeomSubset(
            mesh, f"material_{m}", UsdGeom.Tokens.face, np.flatnonzero(face_material == m).astype(np.int32).tolist(),
            UsdShade.Tokens.materialBind, UsdGeom.Tokens.nonOverlapping)
        UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(materials[m])


def _materials(stage, rig: Rig, images: dict[str, bytes]) -> list:
    """One UsdPreviewSurface material per glTF material of the rig's look, in order."""
    Gf, Sdf, Usd, UsdGeom, UsdShade, UsdSkel, Vt = _pxr()
    look = rig.look
    files = list(images)
    UsdGeom.Scope.Define(stage, "/Rig/Materials")
    out, used = [], set()
    for k, material in enumerate(look.materials):
        name = _unique(re.sub(r"[^A-Za-z0-9_]", "_", material.get("name") or f"material_{k}"), used)
        path = f"/Rig/Materials/{name}"
        usd_material = UsdShade.Material.Define(stage, path)
        surface = UsdShade.Shader.Define(stage, path + "/surface")
        surface.CreateIdAttr("UsdPreviewSurface")
        pbr = material.get("pbrMetallicRoughness", {})
        factor = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])
        surface.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(float(pbr.get("metallicFactor", 1.0)))
        surface.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(float(pbr.get("roughnessFactor", 1.0)))
        if factor[3] < 1.0:
            surface.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(float(factor[3]))
        usd_material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
        reader = None

        def texture(info: dict, label: str, output: str, channels: str):
            nonlocal reader
            texture_index = info.get("index")
            if texture_index is None or texture_index >= len(look.textures):
                return None
            source = look.textures[texture_index].get("source")
            if source is None or source >= len(files):
                return None
            if reader is None:
                reader = UsdShade.Shader.Define(stage, path + "/st")
                reader.CreateIdAttr("UsdPrimvarReader_float2")
                reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
                reader.CreateOutput("result", Sdf.ValueTypeNames.Float2)
            shader = UsdShade.Shader.Define(stage, f"{path}/{label}")
            shader.CreateIdAttr("UsdUVTexture")
            shader.CreateInput("file", Sdf.ValueTypeNames.Asset).Set("./" + files[source])
            shader.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
            sampler = look.samplers[look.textures[texture_index]["sampler"]] \
                if look.textures[texture_index].get("sampler") is not None else {}
            for axis, key in (("wrapS", "wrapS"), ("wrapT", "wrapT")):
                shader.CreateInput(axis, Sdf.ValueTypeNames.Token).Set(_WRAP.get(sampler.get(key, 10497), "repeat"))
            shader.CreateInput("sourceColorSpace", Sdf.ValueTypeNames.Token).Set(
                "sRGB" if label != "normal" else "raw")
            shader.CreateOutput(output, Sdf.ValueTypeNames.Float3 if channels == "rgb" else Sdf.ValueTypeNames.Float)
            return shader

        base = texture(pbr.get("baseColorTexture", {}), "base_color", "rgb", "rgb")
        color = surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
        if base is not None:
            base.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*map(float, factor)))
            color.ConnectToSource(base.ConnectableAPI(), "rgb")
        else:
            color.Set(Gf.Vec3f(*map(float, factor[:3])))
        normal = texture(material.get("normalTexture", {}), "normal", "rgb", "rgb")
        if normal is not None:
            # Normal maps hold [0, 1] colours for [-1, 1] directions.
            normal.CreateInput("scale", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2, 2, 2, 1))
            normal.CreateInput("bias", Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1, -1, -1, 0))
            surface.CreateInput("normal", Sdf.ValueTypeNames.Normal3f).ConnectToSource(normal.ConnectableAPI(), "rgb")
        emissive = material.get("emissiveFactor", [0.0, 0.0, 0.0])
        glow = texture(material.get("emissiveTexture", {}), "emission", "rgb", "rgb")
        if glow is not None:
            surface.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).ConnectToSource(glow.ConnectableAPI(), "rgb")
        elif any(emissive):
            surface.CreateInput("emissiveColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*map(float, emissive)))
        out.append(usd_material)
    return out
