"""The spine of autorig: one line per stage of Baran & Popović's method.

    mesh       -> prepare         canonical frame (one unit tall), private working copy
               -> distance_field  adaptive octree of signed distance, winding-number inside/outside
               -> medial_samples  creases of the distance field: the approximate medial surface
               -> pack_spheres    maximal inscribed spheres, largest first
               -> sphere_graph    spheres joined through the interior
               -> orientation     which axis is up and which way it faces, unless the user said: the
                                  discretization is carried into that frame (+y up, facing +z), with
                                  x = 0 on the body's mid-plane
               -> embed           A* over placements of the template's reduced skeleton
               -> place_on_paths  every template joint along the embedded paths
               -> refine          continuous optimisation of all joints
               -> placement       a learned template's joints pulled towards it (``autorig.embed.placement``)
               -> convention      the joints moved to where the chosen convention's artists put them
                                  (``autorig.embed.convention``)
               -> legs            a four-legged template's leg joints read off the mesh's legs
                                  (``autorig.readoff.legs``)
               -> tips            an upright head's tip up to its crown (``autorig.readoff.crown``)
               -> hands           fingers read off the full-resolution hands: three joints and a tip per
                                  digit (``autorig.hands``), for templates with fingers or ``fingers=True``
               -> bone_heat       skin weights for every input vertex (helper joints ride along, unweighted),
                                  the head's bone heating from the base of the skull; separate pieces take
                                  the weights of the body they sit on (``autorig.weights.pieces``)
               -> confidence      how much to trust the result

``skin`` is the same without the embedding, for the user's own skeleton (``autorig MESH --skeleton FILE``):

    mesh, skeleton file -> prepare    canonical scale, clean working copy
                        -> fit        a BVH's units to the mesh's (or a given scale)
                        -> plan_heat  which bones heat: tips, cold bones, split bones (``autorig.weights.bones``)
                        -> bone_heat  skin weights for every input vertex
"""
from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .input.limits import MAX_FACES
from .result import Rig


@dataclass
class RigOptions:
    """up, front: which input axis points up and which way the character faces (x|y|z|-x|-y|-z), or "auto"
    to detect it (see ``autorig.embed.orient``).
    voxels, max_segments: template "auto" only: grid cells along the longest side of the mesh, and the most
    bones per extracted chain, plus one for each chain hanging from it (see ``autorig.extract``).
    convention: where the joints go by whose habit, of the template's conventions (``autorig.embed.convention``);
    None for the template's default.
    max_faces: a mesh of more triangles is refused (``InputError``) before it is read (None: no limit).
    allow_outside_paths: let a mesh file name textures, MTL files and buffers outside its own folder
    (``autorig.input.confine``).
    fingers: read fingers off the hands (``autorig.hands``) whatever the template says; a template with
    ``"fingers": true`` always gets them.
    markers: a markers file (path) or {name: [x, y, z]} in the input's coordinates (``autorig.markers``): the
    joints they name are held at them, and the axes left "auto" are the markers' when they tell; None for
    none."""
    up: str = "auto"
    front: str = "auto"
    voxels: int = 96
    max_segments: int = 8
    convention: str | None = None
    max_faces: int | None = MAX_FACES
    allow_outside_paths: bool = False
    fingers: bool = False
    markers: str | Path | dict | None = None


def rig(mesh, template="biped", options: RigOptions | None = None) -> Rig:
    """Rig a mesh with a template skeleton.

    mesh: a path (OBJ, PLY, STL, OFF, glTF/GLB) or a pair (vertices [V, 3], faces [F, 3]).
    template: a built-in template name, a path to a template JSON file, a ``Template``, or "auto" for a
        skeleton extracted from the shape itself (``autorig.extract``).
    Returns a ``Rig`` in the input's own coordinates, weights for every input vertex in input order.
    """
    from .weights.attach import bone_heat, start_heat_surface
    from .confidence import rig_confidence, toes_forward
    from .explain import confidence_reasons
    from .embed.convention import convention_named, convention_shift, in_convention
    from .readoff.crown import crown_tip, heat_joints, skull_base
    from .readoff.landmarks import neck_fraction
    from .readoff.midline import centred
    from .input.mesh import prepare
    from .embed.orient import centre_on_mid_plane, detect_orientation, reorient, working_axes
    from .embed.placement import learned_placement
    from .readoff.rest_pose import rest_pose
    from .template import AUTO, Template, load_template
    from .input.budget import SEARCH_SECONDS, budget, heat_seconds

    options = options or RigOptions()
    timings: dict[str, float] = {}
    stage = _stage_timer(timings)

    with stage("load"):
        vertices, faces, name, look = _load(mesh, options)
        template = template if isinstance(template, Template) or template == AUTO else load_template(template)
        markers = _markers(options.markers, template)
    if template == AUTO:
        return _rig_without_template(vertices, faces, name, look, options, stage, timings)
    convention, _ = convention_named(template, options.convention)   # an unknown name fails before the work
    up, front = options.up, options.front
    if markers:     # the axes left "auto" are the markers' when they tell
        from .markers import marker_frame
        up, front = marker_frame(markers, template, vertices[np.unique(faces)], up, front)
    with stage("prepare"):
        prepared = prepare(vertices, faces, *working_axes(up, front), name=name, checked=True,
                           unit=None if up == "auto" else up)
        heat_surface = start_heat_surface(prepared)   # a dense mesh's heat surface, made beside the skeleton
    field, graph = discretize(prepared, stage, None if "auto" in (up, front) else (up, front))
    with budget("the embedding's search", SEARCH_SECONDS):   # the orientation's searches and the embedding's
        with stage("orientation"):
            frame = detect_orientation(prepared, field, graph, template, up, front)
        if up == "auto" and frame.up.lstrip("+-") != "y":
            # The field is measured in heights: detected up not the working frame's, it is discretized again in
            # the units of the up found, as it is when that up is given (the same rig either way).
            with stage("prepare"):
                prepared = prepare(vertices, faces, *working_axes(up, front), name=name, checked=True,
                                   unit=frame.up)
            field, graph = discretize(prepared, stage, (frame.up, frame.front))
    with budget("the embedding's search", SEARCH_SECONDS):
        with stage("orientation"):
            prepared, field, graph = centre_on_mid_plane(*reorient(prepared, field, graph, frame))
        held = _held(markers, template, prepared, vertices, faces, options)
        # Marked joints are put at their markers once the joints are in the convention the markers are in (the
        # rig's own, where the user sees them), and kept there by each stage after it (``autorig.markers``).
        keep = held.apply if held is not None else (lambda joints: joints)
        embedding, joints = embed_and_refine(field, graph, template, stage, held=held)
    with stage("placement"):
        neck = neck_fraction(field) if (template.placement or {}).get("neck") is not None else None
        joints = learned_placement(joints, template, np.ptp(prepared.work_vertices, axis=0), field,
                                   shift=convention_shift(template, convention), neck=neck)
    with stage("convention"):
        joints = keep(in_convention(joints, template, convention, field))
    if template.legs:    # four-legged templates only: the biped has no learned legs and pays nothing
        from .readoff.legs import read_legs, surface_of
        from .readoff.head import read_head
        from .readoff.rump import read_rump
        with stage("legs"):
            joints = read_legs(joints, template, *surface_of(field))
            joints = read_rump(joints, template, field.depth, surface_of(field)[0])
            joints = keep(read_head(joints, template, field.depth, surface_of(field)[0]))
    with stage("tips"):
        # mid-plane joints in the middle of the body's chord across them, then head_end up to the crown
        joints = centred(joints, template, field.depth, prepared.work_vertices)
        joints = keep(crown_tip(joints, template, prepared.vertices, field.depth))
    fingers = None
    if template.fingers or options.fingers:
        from .hands.stage import read_fingers, skin_with_fingers
        with stage("hands"):
            fingers = read_fingers(prepared.vertices, prepared.faces, template.names, joints)
            joints = keep(fingers.moved_joints(template.names, joints))   # an arm short of its hand ends at it
    with stage("skin weights"), budget("the bone heat", heat_seconds(len(faces))):
        surface = heat_surface.result_for(prepared)
        height = float(np.ptp(prepared.work_vertices[:, 1]))     # the canonical frame stands on y
        # the head's bone heats from the base of the skull, wherever the head joint (its pivot) is
        heat = heat_joints(joints, template, skull_base(joints, template, field.depth, prepared.work_vertices))
        weights = (bone_heat(prepared.vertices, prepared.faces, heat, template.parents, surface=surface,
                             height=height)
                   if fingers is None else
                   skin_with_fingers(prepared.vertices, prepared.faces, heat, template.parents, template.names,
                                     fingers, surface=surface, height=height))
    with stage("confidence"):
        # the mesh's toes against its shins: the confidence's feet part, its model's feature and the reasons'
        toes = toes_forward(field.surface_vertices, joints, template)
        confidence, parts = rig_confidence(field, graph, embedding, template, joints, toes)
        reasons = confidence_reasons(field, graph, embedding, template, joints, parts, confidence, toes)
    # Helper joints (IK targets, prop sockets) ride along at their offsets and carry no weight; fingers after.
    J = len(template.names)
    names, parents, body = template.with_helpers(joints)
    weights = np.hstack([weights[:, :J], np.zeros((len(weights), len(template.helpers))), weights[:, J:]])
    if fingers is not None:
        names, parents, joints, weights = fingers.appended(names, parents, body, weights)
    else:
        joints = body

    return Rig(
        names=names, parents=parents, joints=prepared.from_canonical(joints),
        weights=weights, vertices=vertices, faces=faces, template=template.name, timings=timings, look=look,
        info={"up": frame.up, "front": frame.front, "axes_detected": options.up == "auto" or options.front == "auto",
              "orientation_margin": round(frame.margin, 3), "confidence": round(confidence, 3),
              "confidence_parts": parts, "confidence_reasons": reasons,
              "embedding_penalty": round(float(embedding.cost), 4),
              "embedding_optimal": embedding.optimal, "spheres": int(len(graph.radii)),
              "search_expansions": int(embedding.expanded), **rest_pose(joints, template.names),
              **dropped_info(look), **(fingers.info() if fingers is not None else {}),
              **({"convention": convention} if convention else {}),
              **(_markers_info(held, joints, options, up, front) if held is not None else {})})


def _markers(given, template) -> dict | None:
    """{name: point [3]} of ``RigOptions.markers`` (a path or a dict), checked against the template, or None."""
    if given is None:
        return None
    from .errors import InputError
    from .markers import markers_from, read_markers
    from .template import AUTO
    if template == AUTO:
        raise InputError("markers need a template: --template auto makes its own skeleton")
    return read_markers(given, template) if isinstance(given, (str, Path)) else markers_from(given, template)


def _held(markers, template, prepared, vertices, faces, options):
    """The ``autorig.markers.Held`` joints of ``markers`` in ``prepared``'s canonical frame, once the markers
    are checked against the mesh (inside it, left and right as its axes say); None without markers."""
    if not markers:
        return None
    from .markers import check_markers, held_joints
    source = Path(options.markers).name if isinstance(options.markers, (str, Path)) else "markers"
    check_markers(markers, vertices, faces, prepared.rotation[0], prepared.height, source)
    return held_joints(markers, template, prepared.to_canonical)


def _markers_info(held, joints, options, up, front) -> dict:
    """What a rig's ``info`` says of its markers: their names, how far (in heights) the farthest marked joint
    lies from its marker, and which axes the markers chose."""
    chosen = [axis for axis, given, used in (("up", options.up, up), ("front", options.front, front))
              if given != used]
    return {"markers": list(held.names), "marker_error": round(float(held.distances(joints).max()), 5),
            **({"axes_from_markers": chosen} if chosen else {})}


def discretize(prepared, stage=None, axes: tuple[str, str] | None = None):
    """(distance field, sphere graph) of a prepared mesh (``autorig.input.mesh.prepare``), in its canonical frame:
    the stages the embedding needs, shared by ``rig`` and the learner (``autorig.learn``). ``axes``: the
    character's (up, front) in the input's axes when known, if ``prepared`` is in another frame (the rig's
    working frame): the packing breaks exact ties in that frame (``pack_spheres``)."""
    from .discretize.distance import distance_field
    from .discretize.graph import sphere_graph
    from .discretize.medial import medial_samples, pack_spheres
    from .input.limits import MAX_SPHERES, over_budget

    stage = stage or _stage_timer({})
    with stage("distance field"):
        field = distance_field(*prepared.coarse())
    with stage("medial spheres"):
        rotation = None if axes is None else prepared.frame_change(*axes).rotation
        spheres = pack_spheres(medial_samples(field), min_radius=field.finest, rotation=rotation)
        if len(spheres.radii) > MAX_SPHERES:  # the graph, orientation and search grow with their square
            raise over_budget("medial spheres", len(spheres.radii), MAX_SPHERES)
    with stage("sphere graph"):
        graph = sphere_graph(field, spheres)
    return field, graph


def embed_and_refine(field, graph, template, stage=None, max_expansions: int | None = None, held=None):
    """(embedding, joints [J, 3]) of ``template`` in a discretized mesh (``discretize``), canonical frame: the
    discrete embedding, then every joint along its paths and refined, before the learned placement. Shared by
    ``rig`` and the learner's calibration rigs (``autorig.learn.calibrate``), which search with a smaller budget
    (``max_expansions``; None: the search's own). ``held``: the joints the user marked (``autorig.markers``),
    which the embedding puts in the limbs of their markers. Raises ``RigFailedError`` when the template does
    not fit."""
    from .embed import embed
    from .embed.refine import place_on_paths, refine
    from .readoff.tips import along_the_foot, surface_for

    stage = stage or _stage_timer({})
    with stage("embedding"):
        embedding = embed(graph, template, max_expansions, held)

    def placed(embedding):
        return along_the_foot(refine(field, place_on_paths(graph, embedding, template, surface_for(field), field),
                                     template, on_paths=place_on_paths(graph, embedding, template, None, field)),
                              template)
    with stage("refinement"):
        joints = placed(embedding)
    if held is None:
        from .confidence import crossed_pairs
        crossed = crossed_pairs(joints, template)
        if crossed:
            # Shoulders, elbows, hips and knees each on the other's side of the body: a limb's chain ran through
            # the other limb (hands that meet in front of the chest leave which end is whose a near-tie). The
            # ends given to each other are tried, and kept if fewer pairs cross (``crossed_pairs``).
            from .embed import swap_mirrored
            with stage("embedding"):
                other = swap_mirrored(graph, template, embedding, [i for pair in crossed for i in pair])
            if other is not embedding:
                with stage("refinement"):
                    moved = placed(other)
                if len(crossed_pairs(moved, template)) < len(crossed):
                    embedding, joints = other, moved
    return embedding, joints


@dataclass
class SkinOptions:
    """scale: how the skeleton file's positions become the mesh's: a number multiplies them (the mesh's units
    per file unit), "auto" scales and moves the skeleton to fit the mesh's bounding box (see
    ``autorig.weights.bones.fit_to_mesh``); None means "auto" for a BVH file (motion capture units rarely match a
    mesh's) and 1 for JSON and glTF skeletons (taken as they are, in the mesh's coordinates). Anything else
    (zero, negative, not a number) is an ``InputError``. max_faces, allow_outside_paths: as in ``RigOptions``."""
    scale: float | str | None = None
    max_faces: int | None = MAX_FACES
    allow_outside_paths: bool = False

    def __post_init__(self):
        import numbers

        from .errors import InputError
        scale = self.scale
        if scale is not None and scale != "auto" and (isinstance(scale, bool) or not isinstance(scale, numbers.Real)
                                                      or not 0 < scale < float("inf")):
            raise InputError(f"skeleton scale must be a positive number or auto, not {scale!r}")


def skin(mesh, skeleton, options: SkinOptions | None = None) -> Rig:
    """Skin weights of a mesh for the user's own skeleton: no embedding, only bone heat.

    mesh: a path (OBJ, PLY, STL, OFF, glTF/GLB) or a pair (vertices [V, 3], faces [F, 3]).
    skeleton: a path (.json, .glb/.gltf, .bvh; see ``autorig.exchange.skeleton``) or a ``Skeleton``.
    Returns a ``Rig`` with the skeleton's joints (names, hierarchy, parents first) in the mesh's coordinates and
    weights for every input vertex in input order; a glTF skeleton's nodes and bind pose ride along
    (``Rig.joint_nodes``) so that its glTF output keeps them. ``info`` says which leaves carry a tip bone and
    which bones were left cold because they lie outside the mesh or have no length (``autorig.weights.bones``).
    """
    from .weights.attach import bone_heat
    from .weights.bones import fit_to_mesh, plan_heat
    from .input.budget import budget, heat_seconds
    from .exchange.skeleton import Skeleton, read_skeleton
    from .input.mesh import prepare

    options = options or SkinOptions()
    timings: dict[str, float] = {}
    stage = _stage_timer(timings)

    with stage("load"):
        vertices, faces, mesh_name, look = _load(mesh, options)
        name = Path(skeleton).stem if isinstance(skeleton, (str, Path)) else "skeleton"
        skeleton = skeleton if isinstance(skeleton, Skeleton) else read_skeleton(skeleton)
    with stage("prepare"):
        # Only the canonical scale matters here (the rules and the heat do not depend on the mesh's units);
        # the longest side as "up" keeps that scale sane for meshes flat along y.
        extent = np.ptp(vertices[np.unique(faces)], axis=0)
        up, front = (("x", "y", "z")[a] for a in np.argsort(-extent, kind="stable")[:2])
        prepared = prepare(vertices, faces, up, front, name=mesh_name, checked=True)
    with stage("fit"):
        scale = options.scale if options.scale is not None else ("auto" if skeleton.kind == "bvh" else 1.0)
        positions, tips, factor = fit_to_mesh(skeleton.positions, skeleton.tips, vertices[np.unique(faces)],
                                              scale)
        _check_reach(prepared, np.vstack([positions, tips]), list(skeleton.names) * 2)
    with budget("the bone heat", heat_seconds(len(faces))):        # planning the bones and solving their heat
        with stage("bones"):
            plan = plan_heat(prepared.work_vertices, prepared.work_faces, skeleton.names,
                             prepared.to_canonical(positions), skeleton.parents, prepared.to_canonical(tips))
        with stage("skin weights"):
            J = len(skeleton.names)
            # Tip joints are virtual: their bones' heat goes to the leaves (plan.owners): empty columns.
            weights = bone_heat(prepared.vertices, prepared.faces, plan.joints, plan.parents,
                                owners=plan.owners)[:, :J]

    carrying = weights.max(axis=0) > 0
    return Rig(
        names=list(skeleton.names), parents=skeleton.parents.copy(), joints=positions, weights=weights,
        vertices=vertices, faces=faces, template=(skeleton.joint_nodes.skin_name if skeleton.joint_nodes else "")
        or name, timings=timings, joint_nodes=skeleton.joint_nodes, look=look,
        info={"skeleton": skeleton.kind, "skeleton_scale": round(factor, 6),
              "joints_weighted": int(carrying.sum()), "tip_bones": plan.tips,
              "cold_bones": {reason: [f"{skeleton.names[skeleton.parents[skeleton.names.index(c)]]} -> {c}"
                                      for c in children]
                             for reason, children in (("outside", plan.outside), ("along_other_bones", plan.doubled),
                                                      ("zero_length", plan.zero_length)) if children},
              "all_bones_heat": plan.fallback, **dropped_info(look)})


# A joint farther than this many mesh sizes from the mesh is refused: the heat's squared distances would
# overflow long before (a joint at 1e308 gave NaN weights), and no skeleton in other units is that far off.
MAX_REACH = 1e6


def _check_reach(prepared, points, names: list[str]) -> None:
    """SkeletonError if a joint or tip (``points`` [N, 3], NaN for tips not given) lies more than ``MAX_REACH``
    mesh sizes away in the mesh's canonical frame (its longest side 1), or beyond what a float holds."""
    from .errors import SkeletonError
    given = ~np.isnan(points).any(axis=1)
    with np.errstate(over="ignore", invalid="ignore"):
        reach = np.abs(prepared.to_canonical(points[given])).max(axis=1, initial=0.0)
    far = ~(reach <= MAX_REACH)
    if far.any():
        k = int(np.flatnonzero(far)[0])
        raise SkeletonError(f"skeleton: joint {names[int(np.flatnonzero(given)[k])]!r} lies {reach[k]:.3g} mesh "
                            f"sizes from the mesh (more than {MAX_REACH:.0e}): in other units? (--skeleton-scale)")


def _rig_without_template(vertices, faces, name: str, look, options: RigOptions, stage, timings) -> Rig:
    """Template "auto": a skeleton extracted from the shape (Wade & Parent 2002, ``autorig.extract``), then the
    same skin weights. The extraction does not depend on the axes, so axes left "auto" are not detected."""
    from .weights.attach import bone_heat
    from .input.budget import budget, heat_seconds
    from .extract import (connected_medial, control_skeleton, distance_map, fixed_axes, inside_graph,
                          medial_surface, path_tree, skeleton_confidence, skeleton_reasons, voxelize)
    from .input.mesh import prepare

    up, front = fixed_axes(options.up, options.front)
    with stage("prepare"):
        prepared = prepare(vertices, faces, up, front, name=name, checked=True)
    with stage("voxels"):
        grid = voxelize(prepared.work_vertices, prepared.work_faces, options.voxels)
    with stage("distance map"):
        depth = distance_map(grid, prepared.work_vertices, prepared.work_faces)
    with stage("medial surface"):
        solid = inside_graph(depth)
        medial = connected_medial(solid, medial_surface(depth))
        if len(medial.voxels) < 2:
            medial = solid          # a ball's medial surface is its centre alone: grow the path in the solid
    with stage("path tree"):
        tree = path_tree(medial)
    with stage("control skeleton"):
        joints, template = control_skeleton(tree, grid, options.max_segments)
    with stage("skin weights"), budget("the bone heat", heat_seconds(len(faces))):
        weights = bone_heat(prepared.vertices, prepared.faces, joints, template.parents)
    with stage("confidence"):
        confidence, parts = skeleton_confidence(prepared.work_vertices, prepared.work_faces, joints,
                                                template.parents, tree.candidates)

    return Rig(
        names=list(template.names), parents=template.parents.copy(), joints=prepared.from_canonical(joints),
        weights=weights, vertices=vertices, faces=faces, template=template.name, timings=timings, look=look,
        # The confidence: joints inside, how clearly the limbs stood out from the bumps, left-right symmetry
        # (``autorig.extract.confidence``).
        info={"up": up, "front": front, "axes_detected": False, "confidence": round(confidence, 3),
              "confidence_parts": parts, "confidence_reasons": skeleton_reasons(parts),
              "joints_inside": parts["inside"], "inside_voxels": int(grid.inside.sum()),
              "voxel_size": round(grid.step, 5),
              "medial_voxels": int(len(medial.voxels)), "chains": len(tree.paths), **dropped_info(look)})


def _load(mesh, options) -> tuple[np.ndarray, np.ndarray, str, object]:
    """(vertices [V, 3], faces [F, 3], the name errors use, the input's ``Look`` or None) of a mesh path or
    (vertices, faces) pair, checked, with the ``options``' limits."""
    from .input.limits import check_faces
    from .input.mesh import check_mesh
    from .input.read import read_input

    if isinstance(mesh, (str, Path)):
        vertices, faces, look = read_input(mesh, options.max_faces, options.allow_outside_paths)
        return vertices, faces, Path(mesh).name, look
    vertices, faces = check_mesh(*mesh, "mesh")
    check_faces(len(faces), options.max_faces, "mesh")
    return vertices, faces, "mesh", None


def dropped_info(look) -> dict:
    """``{"dropped": [...]}``, what of the input's look was left out (``autorig.input.confine.Dropped``), for a rig's
    ``info``; {} when nothing was, so that ordinary rigs stay as they were."""
    return {"dropped": [d.as_dict() for d in look.dropped]} if look is not None and look.dropped else {}


def _stage_timer(timings: dict[str, float]):
    @contextmanager
    def stage(name: str):
        start = time.perf_counter()
        yield
        timings[name] = timings.get(name, 0.0) + time.perf_counter() - start   # a stage run twice: both
    return stage
