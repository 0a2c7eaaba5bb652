"""``autorig learn``: templates learned from rigged characters.

    examples  -> read        corpus folders (a map to the base template's joints) or rigged glTF files
              -> skeleton    the base template's joints, or the examples' own (weighted joints, tips, helpers)
              -> positions   each example in the template frame; the mean, made symmetric
              -> features    mirror pairs, feet, fat joints (``proportions``)
              -> discretize  each example's sphere graph, in its own frame and facing the wrong ways
              -> Γ           max-margin penalty weights (``gamma``)
              -> head/tail   how much orientation detection weighs the head/tail cues (``head_tail``, ``head_bulk``)
              -> legs        where leg joints sit on the legs the mesh shows (``legs``, four-legged templates)
              -> confidence  a calibrated model, on rigs of held-out folds, of the examples as they are and
                             re-proportioned (``calibrate``, ``augment``)

The result is a ``Template`` that ``--template`` takes once written with ``Template.to_dict``.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..template import Helper, Template
from .examples import Example, read_examples
from .proportions import (example_positions, fat_joints, feet, fill_from_others, mirror_pairs, skeleton_of_base,
                          skeleton_of_examples, symmetrized)

FOLDS = 3   # calibration folds (whole groups of examples held out together)
# What a template can learn. "conventions" splits the placement's offset by the examples' sources
# (``autorig.embed.convention``): it needs "placement", the shared anatomy the conventions are offsets from.
PARTS = ("proportions", "penalties", "orientation", "placement", "conventions", "legs", "confidence")


@dataclass
class Learned:
    """template: the learned Template; examples: their names; spread [J] RMS distance of the examples' joints
    from the template's (template units); gamma: the max-margin rounds; confidence: the model's record."""
    template: Template
    examples: list[str]
    spread: np.ndarray
    gamma: list
    confidence: dict


def learn_template(paths, base: Template | None = None, name: str | None = None, progress=None,
                   parts=PARTS, conventions: dict[str, list[str]] | None = None,
                   default: str | None = None) -> Learned:
    """A template learned from the rigged characters under ``paths`` (``examples.expand``).

    base: the template whose joint names corpus folders map to (its joints are the learned template's);
        None for rigged glTF files, whose own joint names and hierarchy are used.
    progress: a callable taking one line of text, or None.
    parts: what to learn, of ``PARTS``; with a base, what is not learned is the base's (its proportions,
        its penalty weights, no placement, its confidence formula). Cross-validation decides what pays.
    conventions: {name: [sources]}, the named conventions to ship (``learn.conventions.named_sources``);
    default: the convention rigs take unless told (else the one most examples follow).
    """
    from ..errors import TemplateError
    unknown = sorted(set(parts) - set(PARTS))
    if "conventions" in parts and "placement" not in parts:
        raise TemplateError("cannot learn conventions without placement: they are offsets from its anatomy")
    if unknown or (base is None and "proportions" not in parts):
        raise TemplateError(f"cannot learn {unknown or 'without proportions'}: the parts are {', '.join(PARTS)}"
                            " (proportions needed without a base template)")
    say = progress or (lambda _line: None)
    examples = read_examples(paths, base)
    say(f"{len(examples)} examples")
    if "conventions" in parts:
        from .conventions import named_sources
        known = named_sources([e.source for e in examples], conventions)
        if default is not None and default not in known:
            raise TemplateError(f"no examples for the convention {default!r} (the examples' sources: "
                                f"{', '.join(sorted({e.source for e in examples}))})")
    skeleton = skeleton_of_base(base) if base is not None else skeleton_of_examples(examples)
    per_example = fill_from_others(np.array([example_positions(e, skeleton, base) for e in examples]),
                                   skeleton.parents)
    extents = np.array([np.ptp(e.prepared().work_vertices, axis=0) for e in examples])
    template = _template(skeleton, per_example, examples, base, name)
    if "proportions" not in parts:
        template = replace(template, positions=base.positions.copy())
    settings, fields, cues = _settings(examples, per_example, say)
    depths = np.mean([np.maximum(f.depth(p), 0.0) for f, p in zip(fields, per_example)], axis=0)
    template = replace(template, fat=tuple(_fat(template, depths)))
    gamma_rounds = []
    if "penalties" in parts:
        from .gamma import learn_weights
        report = learn_weights(_reduced_settings(settings, template), template, progress=say)
        template = replace(template, penalty_weights=report.weights)
        gamma_rounds = report.rounds
    head_tail = {}
    if "orientation" in parts:
        from .head_tail import learn_head_tail
        weights, head_tail = learn_head_tail(settings, cues, template)
        template = replace(template, **weights)
        say(f"head/tail cue weights {weights['head_tail']:.2f} (outline), {weights['head_bulk']:.2f} (ends' bulk), "
            f"{weights['head_share']:.2f} (weight share), {weights['head_crest']:.2f} (crest), "
            f"{weights['head_toes']:.2f} (toes), front/back embedding difference bounded at "
            f"{weights['head_gap']}: "
            f"examples whose own frame does not win clearly {head_tail.get('unclear_without')} without them, "
            f"{head_tail.get('unclear_with')} with them")
    legs = {}
    if "legs" in parts:
        from .legs import learn_legs
        rules, legs = learn_legs(examples, per_example, template)
        template = replace(template, legs=rules or None)
        say(f"legs: {legs['legs_measured']} of {legs['legs_total']} measured, rules for {len(rules)} joints")
    confidence = {}
    if "placement" in parts or "confidence" in parts:
        template, confidence = _calibrated(template, skeleton, examples, per_example, extents, settings, say,
                                           parts, (conventions or {}) if "conventions" in parts else None, default)
    spread = np.sqrt(np.mean(np.sum((per_example - template.positions) ** 2, axis=2), axis=0))
    record = {"examples": [e.name for e in examples], "base": base.name if base is not None else None,
              "sources": {source: [e.name for e in examples if e.source == source]
                          for source in sorted({e.source for e in examples})},
              **({"conventions": {n: c["sources"] for n, c in template.conventions.items()},
                  "default_convention": template.default_convention} if template.conventions else {}),
              "learned": [p for p in PARTS if p in parts],
              "penalty_rounds": gamma_rounds, "head_tail": head_tail, **({"legs": legs} if legs else {}),
              "mean_spread": round(float(np.mean(spread)), 4), "confidence": confidence}
    template = replace(template, learned_from=record)
    return Learned(template, [e.name for e in examples], spread, gamma_rounds, confidence)


def _template(skeleton, per_example: np.ndarray, examples: list[Example], base: Template | None,
              name: str | None) -> Template:
    """The mean skeleton of the examples [N, J, 3], symmetric, with its mirror pairs, feet and helpers
    (fat joints come later)."""
    mean = per_example.mean(axis=0)
    pairs = (list(base.symmetry) if base is not None else mirror_pairs(mean, skeleton.parents))
    positions = symmetrized(mean, pairs)
    helpers = []
    for helper, parent in skeleton.helpers:
        offsets = [e.canonical_joints()[e.key_of[helper]] - p[parent] for e, p in zip(examples, per_example)]
        helpers.append(Helper(helper, parent, tuple(float(v) for v in np.mean(offsets, axis=0))))
    foot = list(base.feet) if base is not None else feet(positions, skeleton.parents)
    return Template(name=name or (base.name if base is not None else "learned"), names=tuple(skeleton.names),
                    parents=skeleton.parents.copy(), positions=positions, symmetry=tuple(pairs),
                    feet=tuple(foot), fat=tuple(base.fat) if base is not None else (),
                    penalty_weights=dict(base.penalty_weights) if base is not None and base.penalty_weights
                    else None, helpers=tuple(helpers), fingers=base.fingers if base is not None else False)


def _settings(examples, per_example, say):
    """The learner's view of every example: (settings for Γ, fields [N], the outline's head/tail cue in each
    setting) with the full truth [J, 3] in each setting (``_reduced_settings`` picks the reduced joints)."""
    from ..embed.orient import _handicap, head_tail_cue
    from ..pipeline import discretize
    from .gamma import Setting
    settings, fields, cues = [], [], []
    for n, (example, truth) in enumerate(zip(examples, per_example)):
        prepared = example.prepared()
        field, graph = discretize(prepared)
        fields.append(field)
        for up, front in _frames(example.up, example.front):
            change = prepared.frame_change(up, front)
            moved = change.apply(prepared.work_vertices)
            extent = np.ptp(moved, axis=0)
            cues.append(head_tail_cue(moved))
            if (up, front) == (example.up, example.front):
                settings.append(Setting(graph, truth, _handicap(up, front), n, field, "own", extent))
                continue
            settings.append(Setting(graph.moved(change.apply(graph.centers), change.scale), change.apply(truth),
                                    _handicap(up, front), n,
                                    field.moved(change.rotation, change.offset, change.scale),
                                    "back" if (up, front[-1]) == (example.up, example.front[-1]) else "other",
                                    extent))
        say(f"discretized {example.name} ({len(graph.radii)} spheres)")
    return settings, fields, cues


def _frames(up: str, front: str) -> list[tuple[str, str]]:
    """The example's own frame first, then every frame orientation detection may weigh against it: up and
    front along the example's up and front axes, either way round (``orient.candidate_frames``), and facing
    sideways."""
    from ..embed.orient import AXES, candidate_frames
    left = next(a for a in AXES if a not in (up[-1], front[-1]))
    frames = candidate_frames("auto", "auto", AXES.index(left)) + [(up, left), (up, "-" + left)]
    return [(up, front)] + [f for f in dict.fromkeys(frames) if f != (up, front)]


def _reduced_settings(settings, template):
    joints = template.reduced().joints
    return [replace(s, truth=s.truth[joints]) for s in settings]


def _fat(template: Template, depths: np.ndarray) -> list[int]:
    """Fat joints from the examples' mean depths [J] (``proportions.fat_joints``); the template's if it has
    some."""
    tips = np.array([template.is_tip(j) for j in range(len(template.names))])
    learned = fat_joints(depths, template.parents, tips)
    return list(template.fat) or learned


def group_of(example: Example) -> str:
    """Examples that share a body mesh (the corpus's first part file), else each on its own."""
    parts = example.meta.get("parts") or []
    return str(parts[0].get("file")) if parts and isinstance(parts[0], dict) else example.name


def _calibrated(template, skeleton, examples, per_example, extents, settings, say, parts=PARTS, names=None,
                default=None):
    """``template`` with its learned placement (and, with ``names`` {convention: [sources]}, its conventions)
    and a confidence model, all fitted on rigs of held-out folds (``placement.fit_alpha``,
    ``learn.conventions``, ``calibrate``)."""
    from .calibrate import fit, rig_sample, sample_row
    groups = sorted({group_of(e) for e in examples})
    fold_of_group = {g: k % FOLDS for k, g in enumerate(groups)}
    folds = np.array([fold_of_group[group_of(e)] for e in examples])
    log_lengths = _log_lengths(per_example, template.parents)
    sigma = np.concatenate([[0.0], log_lengths.std(axis=0)[1:]])
    scored = [np.array([skeleton.source[j] is not None and skeleton.source[j] in e.key_of
                        and not template.is_tip(j) for j in range(len(template.names))]) for e in examples]
    # Each fold is rigged by a template whose proportions did not see it.
    held_out_of = {fold: (replace(template, positions=symmetrized(per_example[folds != fold].mean(axis=0),
                                                                  list(template.symmetry)))
                          if "proportions" in parts else template) for fold in sorted(set(folds.tolist()))
                   if (folds != fold).sum() >= 2}
    samples, sample_folds, sample_examples = [], [], []
    for fold, held_out in held_out_of.items():
        for s in settings:
            # The example's own frame and the one facing backwards: rigs that are right and rigs that are not.
            if folds[s.example] != fold or not (s.true_frame or s.frame == "back"):
                continue
            sample = rig_sample(s.field, s.graph, held_out, s.truth, scored[s.example], s.true_frame, s.extent)
            if sample is not None:
                samples.append(sample)
                sample_folds.append(fold)
                sample_examples.append(s.example)
        say(f"calibration fold {fold + 1}/{len(set(folds.tolist()))}: {len(samples)} rigs")
    sample_folds = np.array(sample_folds)
    mean_extent = extents.mean(axis=0)
    placing = "placement" in parts and any(s.own_frame for s in samples)
    def sources_of(ns):
        return None if names is None else [examples[n].source for n in ns]
    shifts = None
    if names is not None:
        from .conventions import source_shifts
        # Where each source puts the joints against the mean of all: the placement's pull, per convention.
        shifts = source_shifts(per_example, np.array(scored), [e.source for e in examples], template)
    if placing:
        template = _placed(template, samples, mean_extent, sources_of(sample_examples), names, default, shifts)
    if "confidence" not in parts:
        return template, {}
    # The confidence sees each calibration rig placed as a new character would be: by the placement fitted on
    # the other folds (fitted on the rig itself, it would look better than it will).
    placed_by = {}
    for fold in sorted(set(sample_folds.tolist())):
        others = [o for o, f in zip(samples, sample_folds) if f != fold]
        other_examples = [n for n, f in zip(sample_examples, sample_folds) if f != fold]
        placed_by[fold] = (_placed(template, others, mean_extent, sources_of(other_examples), names, default,
                                   shifts)
                           if placing and any(o.own_frame for o in others) else template)
    # Rigs of the examples re-proportioned (``augment``): right rigs of characters unlike the corpus's one
    # skeleton, and the wrong rigs such characters get, so that the model learns what unusual proportions
    # say about a rig rather than taking every one for a wrong rig.
    varied = _varied_samples(template, skeleton, examples, per_example, scored, folds,
                             {f: t for f, t in held_out_of.items() if f in placed_by}, say)
    # Each calibration rig in its own example's convention, as its artist would have it.
    def row(s, fold, n):
        from .conventions import convention_for_source
        own = convention_for_source(placed_by[fold].conventions or {}, examples[n].source)
        return sample_row(s, placed_by[fold], sigma, own)
    rows = [row(s, fold, n) for s, fold, n in zip(samples, sample_folds, sample_examples)]
    rows += [row(s, fold, n) for s, fold, n in varied]
    worst = np.array([w for _, w in rows])
    if len(rows) < 2:
        return template, {"skipped": "too few calibration rigs"}
    model = fit([r for r, _ in rows], worst, sigma)
    return replace(template, confidence=model.to_dict()), model.record


def _varied_samples(template, skeleton, examples, per_example, scored, folds, held_out_of, say) -> list:
    """[(calibration rig, fold, example index)] of each example's ``augment.VARIANTS`` re-proportioned variants, in their own
    frame, rigged by the template of the folds that did not see the example."""
    from ..pipeline import discretize
    from .augment import VARIANTS, varied
    from .calibrate import rig_sample
    out = []
    for n, example in enumerate(examples):
        fold = int(folds[n])
        if fold not in held_out_of:
            continue
        for variant in range(VARIANTS):
            changed = varied(example, skeleton, template, variant)
            # Joints the variant cannot place (a tip without vertices) as the examples place them; they are
            # never scored, but the placement needs every joint.
            truth = fill_from_others(np.concatenate([per_example, [example_positions(changed, skeleton, None)]]),
                                     skeleton.parents)[-1]
            prepared = changed.prepared()
            field, graph = discretize(prepared)
            sample = rig_sample(field, graph, held_out_of[fold], truth, scored[n], True,
                                np.ptp(prepared.work_vertices, axis=0))
            if sample is not None:
                out.append((sample, fold, n))
    say(f"calibration: {len(out)} rigs of re-proportioned examples")
    return out


def _placed(template, samples, mean_extent: np.ndarray, sources: list[str] | None = None, names=None,
            default=None, shifts: dict | None = None):
    """``template`` with the placement (alpha, then the offset) fitted on the own-frame rigs among ``samples``;
    with the samples' ``sources``, the offset is one per named convention (``names`` {name: [sources]}), in the
    joints' own frames (``learn.conventions``), instead of one for all, as a fraction of the box."""
    from ..embed.placement import fit_alpha, fit_offset, learned_placement
    own = [s for s in samples if s.own_frame]
    known = [s.scored.astype(float) for s in own]
    truths, boxes = [s.truth for s in own], [s.extent for s in own]
    own_sources = [source for s, source in zip(samples, sources) if s.own_frame] if sources is not None else None
    own_shifts = [shifts[source] for source in own_sources] if shifts and own_sources else None
    neck = mean_neck(own, mean_extent)
    template = replace(template, placement={"extent": mean_extent.tolist(), **({"neck": neck} if neck else {})})
    necks = [s.neck for s in own]
    alpha = fit_alpha([s.refined for s in own], truths, boxes, template, mean_extent, known, own_shifts, necks)
    template = replace(template, placement={**template.placement, "alpha": alpha.tolist()})
    placed = [learned_placement(s.refined, template, s.extent, shift=None if own_shifts is None else own_shifts[n],
                                neck=s.neck) for n, s in enumerate(own)]
    if sources is not None:
        from .conventions import default_convention, fit_conventions
        plain = ([learned_placement(s.refined, template, s.extent, neck=s.neck) for s in own] if own_shifts
                 else placed)
        conventions = fit_conventions(placed, plain, truths, [k > 0 for k in known],
                                      [s.field.depth(p) for s, p in zip(own, placed)], own_sources, template,
                                      names, shifts)
        return replace(template, conventions=conventions,
                       default_convention=default_convention(conventions, default if default in conventions
                                                             else None))
    offset = fit_offset(placed, truths, boxes, template, mean_extent, known)
    return replace(template, placement={**template.placement, "offset": offset.tolist()})


def mean_neck(samples, mean_extent: np.ndarray) -> float | None:
    """The examples' mean neck height (fraction of their height) for the placement's stretch about the neck,
    or None: for templates that stand upright (taller than long: a quadruped's neck is not a height) and
    where at least half of the ``samples`` show a neck."""
    necks = [s.neck for s in samples if s.neck is not None]
    if mean_extent[1] <= mean_extent[2] or 2 * len(necks) < len(samples):
        return None
    return float(np.mean(necks))


def _log_lengths(per_example: np.ndarray, parents: np.ndarray) -> np.ndarray:
    """[N, J] log length of each joint's incoming bone in each example (0 for the root)."""
    child = np.flatnonzero(parents >= 0)
    out = np.zeros(per_example.shape[:2])
    out[:, child] = np.log(np.maximum(np.linalg.norm(per_example[:, child] - per_example[:, parents[child]],
                                                     axis=2), 1e-6))
    return out
