"""USD output (UsdSkel through usd-core): usd-core's own validators find no errors, and UsdSkel's own skinning of
the written mesh under a posed skeleton is autorig's."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rig_samples import rigged_mannequin

from autorig.exchange import write_rig
from autorig.exchange.gltf import top4_influences
from autorig.show.pose import skin

pxr = pytest.importorskip("pxr", reason="usd-core is not installed (pip install 'autorig[usd]')")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, UsdSkel, UsdValidation, Vt  # noqa: E402

TEXTURED = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "textured"


def validation_errors(stage) -> list[str]:
    """Messages of usd-core's validators (every registered one) that are errors."""
    registry = UsdValidation.ValidationRegistry()
    context = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    return [f"{e.GetName()}: {e.GetMessage()}" for e in context.Validate(stage)
            if e.GetType() == UsdValidation.ValidationErrorType.Error]


@pytest.fixture(scope="module")
def mannequin():
    return rigged_mannequin()[1]


@pytest.fixture(scope="module")
def textured_pig():
    mesh = TEXTURED / "Babi" / "Babi.obj"
    if not mesh.is_file():
        pytest.skip("../shared/data/textured is not there")
    import autorig
    return autorig.rig(str(mesh), "quadruped")


def random_pose(rig, seed: int):
    """(local rotations [J, 3, 3], world rotations [J, 3, 3], joint positions [J, 3]) of a random pose."""
    from scipy.spatial.transform import Rotation
    local = Rotation.from_rotvec(np.random.default_rng(seed).normal(0, 0.5, (len(rig.names), 3))).as_matrix()
    world, positions = np.empty_like(local), np.empty((len(rig.names), 3))
    for j, p in enumerate(rig.parents):
        if p < 0:
            world[j], positions[j] = local[j], rig.joints[j]
        else:
            world[j] = world[p] @ local[j]
            positions[j] = positions[p] + world[p] @ (rig.joints[j] - rig.joints[p])
    return local, world, positions


@pytest.mark.parametrize("kind", ["usda", "usdc", "usdz"])
def test_usd_passes_usd_cores_validators_and_holds_the_skeleton(mannequin, tmp_path, kind):
    path = tmp_path / f"hero.{kind}"
    write_rig(mannequin, path, kind)
    stage = Usd.Stage.Open(str(path))
    assert validation_errors(stage) == []
    root = stage.GetDefaultPrim()
    assert root.IsA(UsdSkel.Root)
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0 and UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    skeleton = UsdSkel.Skeleton(stage.GetPrimAtPath("/Rig/Skeleton"))
    joints = list(skeleton.GetJointsAttr().Get())
    assert [j.rsplit("/", 1)[-1] for j in joints] == mannequin.names
    assert joints[mannequin.names.index("left_elbow")] == "hips/spine/chest/left_shoulder/left_elbow"
    bind = np.array(skeleton.GetBindTransformsAttr().Get())
    np.testing.assert_allclose(bind[:, 3, :3], mannequin.joints, atol=1e-9)


def test_usdskel_skins_the_mesh_as_autorig_does(mannequin, tmp_path):
    path = tmp_path / "hero.usdc"
    write_rig(mannequin, path, "usdc")
    stage = Usd.Stage.Open(str(path))
    local, world, positions = random_pose(mannequin, seed=3)
    # A SkelAnimation in the session layer poses the skeleton; the file itself stays as written.
    stage.SetEditTarget(stage.GetSessionLayer())
    animation = UsdSkel.Animation.Define(stage, "/Rig/Pose")
    skeleton = UsdSkel.Skeleton(stage.GetPrimAtPath("/Rig/Skeleton"))
    animation.CreateJointsAttr(skeleton.GetJointsAttr().Get())
    rest = np.array(skeleton.GetRestTransformsAttr().Get())
    animation.CreateTranslationsAttr(Vt.Vec3fArray([Gf.Vec3f(*m[3, :3]) for m in rest]))
    from scipy.spatial.transform import Rotation
    quaternions = Rotation.from_matrix(local).as_quat()  # x, y, z, w
    animation.CreateRotationsAttr(Vt.QuatfArray([Gf.Quatf(float(w), float(x), float(y), float(z))
                                                 for x, y, z, w in quaternions]))
    animation.CreateScalesAttr(Vt.Vec3hArray([Gf.Vec3h(1, 1, 1)] * len(local)))
    UsdSkel.BindingAPI.Apply(skeleton.GetPrim()).CreateAnimationSourceRel().SetTargets([animation.GetPath()])

    cache = UsdSkel.Cache()
    root = UsdSkel.Root(stage.GetDefaultPrim())
    cache.Populate(root, Usd.PrimDefaultPredicate)
    query = cache.GetSkelQuery(skeleton)
    transforms = query.ComputeSkinningTransforms(Usd.TimeCode.Default())
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/Rig/mesh"))
    points = mesh.GetPointsAttr().Get()
    binding = cache.GetSkinningQuery(mesh.GetPrim())
    assert binding.ComputeSkinnedPoints(transforms, points, Usd.TimeCode.Default())
    theirs = np.array(points)

    # autorig's linear blend skinning with the 4 strongest influences, which USD and glTF both hold.
    slots, amounts = top4_influences(mannequin.weights)
    four = np.zeros_like(mannequin.weights)
    np.add.at(four, (np.arange(len(four))[:, None], slots), amounts)  # empty slots hold joint 0 with weight 0
    from dataclasses import replace
    ours = skin(replace(mannequin, weights=four), world, positions)
    assert np.abs(theirs - ours).max() < 1e-4 * np.ptp(mannequin.vertices, axis=0).max()
    assert np.abs(ours - mannequin.vertices).max() > 0.1   # the pose really moves the mesh


def test_textured_usdz_keeps_uvs_material_and_the_image_bytes(textured_pig, tmp_path):
    path = tmp_path / "pig.usdz"
    write_rig(textured_pig, path, "usdz")
    stage = Usd.Stage.Open(str(path))
    assert validation_errors(stage) == []
    mesh = next(UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh))
    st = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st")
    assert st and len(st.Get()) == len(mesh.GetPointsAttr().Get()) == len(textured_pig.look.vertex_of)
    uv = np.array(st.Get())
    np.testing.assert_allclose(uv[:, 1], 1 - textured_pig.look.texcoords[0][:, 1], atol=1e-6)
    material, _ = UsdShade.MaterialBindingAPI(mesh.GetPrim()).ComputeBoundMaterial()
    texture = UsdShade.Shader(material.GetPrim().GetChild("base_color"))
    asset = texture.GetInput("file").Get()
    stored = bytes(Sdf.ZipFile.Open(str(path)).GetFile(asset.path.removeprefix("./")))
    assert stored == (TEXTURED / "Babi" / "Tex.png").read_bytes()


def test_cli_writes_usd_from_the_extension(tmp_path):
    mesh = tmp_path / "hero.obj"
    from autorig.exchange.obj import write_obj
    rig = rigged_mannequin()[1]
    write_obj(rig.vertices, rig.faces, mesh)
    run = subprocess.run([sys.executable, "-m", "autorig.cli", str(mesh), "-o", str(tmp_path / "hero.usda")],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert Usd.Stage.Open(str(tmp_path / "hero.usda")).GetDefaultPrim().IsA(UsdSkel.Root)
