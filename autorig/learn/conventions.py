"""Conventions learned per source: where each studio's artists put the joints, apart from the shared anatomy.

Every example carries its source (``source_of``: a corpus folder's ``source_group``, else its name's prefix,
``0ad_boar`` -> ``0ad``, else the folder it lies in). On the calibration rigs (held-out folds, placed by the
shared anatomy), each example's offset from its artist's joints is measured in the joints' own frames
(``autorig.embed.convention.local_offsets``); a source's convention is the median over its examples (one rig the
embedding got wrong does not move it), shrunk toward the mean of all sources' by ``SHRINK`` examples' worth (a
ridge prior), so that a source of one or two characters does not make a convention of one artist's odd joint.

A convention has two parts. Its ``shift`` [J, 3] is where its source's examples put the joints on average against
the template's mean of all (template frame): what the learned placement pulls a rig towards, so that a source
whose thigh joints sit above the pelvis is not pulled half way to another's femoral heads. Its ``offsets``
[J, 3] are what is still left between those placed rigs and the artists' joints, in the joints' own frames.

Named conventions (``autorig learn --convention NAME=SOURCE,...``) are what a template ships: a name for one
source's (``mixamo=makehuman``), or the mean of several sources' that follow one habit, each family of sources
counting once however many examples and rigs it has (``engine=rigged,makehuman,makehuman-ue``: the engines'
humanoid, hip joints at the femoral heads, is half the glTF samples' habit and half MakeHuman's, its Mixamo and
its Unreal-style rig a quarter each: one tool's bodies under two rigs agree on all but the spine, and counted as
two they outvoted the other studio two to one). A source no name covers ships under its own name. A convention
named for several sources is for characters from none of them: it has no shift (their shifts are their own bodies' proportions as much as their
artists' habit: the glTF samples' stylised short legs, MakeHuman's long ones), and its offsets are measured on
rigs placed by the shared anatomy alone.
"""
from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from ..embed.convention import local_offsets

# How many examples' worth of pull toward the mean of the sources' conventions each one gets per joint.
SHRINK = 2.0


def source_of(example, path: Path | None = None) -> str:
    """The source (studio, game, tool) ``example`` comes from: its ``source_group``, else, for a corpus folder,
    the prefix of a name like ``0ad_boar``, else the name of the folder its file or folder lies in (a studio's
    rigged .glb files: ``studio/knight_a.glb`` is the studio's, whatever its name)."""
    group = example.meta.get("source_group")
    if isinstance(group, str) and group:
        return group
    if example.meta and "_" in example.name:
        return example.name.split("_", 1)[0]
    return Path(path).resolve().parent.name if path is not None else example.name


def source_family(source: str) -> str:
    """The family ``source`` belongs to: the part of its name before a hyphen (``makehuman-ue`` is MakeHuman's
    bodies under an Unreal-style rig, of the ``makehuman`` family). A family's sources share their bodies, so
    they are held out together (``benchmarks/sources.py``) and count once in a pooled convention."""
    return source.split("-")[0]


def named_sources(sources: list[str], names: dict[str, list[str]] | None) -> dict[str, list[str]]:
    """{convention name: [sources]}: the ``names`` given (their sources among ``sources``), and each source no
    name covers under its own name."""
    present = sorted(set(sources))
    out = {name: sorted(s for s in set(members) if s in present) for name, members in (names or {}).items()}
    out = {name: members for name, members in out.items() if members}
    covered = {s for members in out.values() for s in members}
    out.update({s: [s] for s in present if s not in covered})
    return dict(sorted(out.items()))


def convention_for_source(conventions: dict, source: str) -> str | None:
    """The name a template's ``conventions`` give ``source``'s own habit: the one of that source alone, else
    the smallest that includes it; None when none does."""
    mine = [(len(c.get("sources", [])), name) for name, c in conventions.items() if source in c.get("sources", [])]
    return min(mine)[1] if mine else None


def source_shifts(positions: np.ndarray, known: np.ndarray, sources: list[str], template,
                  shrink: float = SHRINK) -> dict[str, np.ndarray]:
    """{source: shift [J, 3]}: the mean of each source's examples' joints ``positions`` [N, J, 3] (template
    frame) where they have them (``known`` [N, J] bool), shrunk toward the mean of the sources', against the
    template's ``positions``; mirror images made symmetric."""
    present = sorted(set(sources))
    rows = [np.array([s == source for s in sources]) for source in present]
    deviation = np.asarray(positions, float) - template.positions
    shrunk = _shrunk([deviation[r] for r in rows], [np.asarray(known, bool)[r] for r in rows], shrink, np.mean)
    mirror = np.array([-1.0, 1.0, 1.0])
    out = {}
    for source, shift in zip(present, shrunk):
        for i, j in template.symmetry:
            shift[i] = (shift[i] + shift[j] * mirror) / 2
            shift[j] = shift[i] * mirror
        out[source] = shift
    return out


def fit_conventions(placed: list[np.ndarray], plain: list[np.ndarray], truths: list[np.ndarray],
                    known: list[np.ndarray], depths: list[np.ndarray], sources: list[str], template,
                    names: dict[str, list[str]] | None, shifts: dict[str, np.ndarray] | None = None,
                    shrink: float = SHRINK) -> dict:
    """{name: {"offsets": [J, 3], "shift": [J, 3] (one source's), "sources": [...], "examples": n}} of each
    named convention (``named_sources``), from the rigs ``placed`` [N][J, 3] (canonical frame, placed by the
    anatomy pulled by their sources' ``shifts``) and ``plain`` [N][J, 3] (placed without a shift), their
    ``truths`` [N][J, 3], the joints each example has ``known`` [N][J] (bool), the rigs' joint depths ``depths``
    [N][J] and the examples' ``sources`` [N]. A convention named for several sources has the mean of their
    offsets measured on the plain rigs and no shift."""
    J = len(template.names)
    has = np.array(known, bool)
    present = sorted(set(sources))
    rows = [np.array([s == source for s in sources]) for source in present]

    def per_source(rigs):
        offsets = np.array([local_offsets(p, t, template, d) for p, t, d in zip(rigs, truths, depths)])
        return _shrunk([offsets[r] for r in rows], [has[r] for r in rows], shrink, np.median)

    own, generic = per_source(placed), per_source(plain) if shifts else None
    tips = [j for j in range(J) if template.is_tip(j)]
    out = {}
    for name, members in named_sources(sources, names).items():
        pooled = len((names or {}).get(name, [name])) > 1
        offsets = generic if pooled and generic is not None else own
        mean = _symmetric(_family_mean({s: offsets[present.index(s)] for s in members}), template)
        mean[tips] = 0.0
        out[name] = {"offsets": mean.tolist(), "sources": members,
                     "examples": int(sum(s in members for s in sources))}
        if shifts and not pooled:
            out[name]["shift"] = shifts[members[0]].tolist()
    return out


def _shrunk(values: list[np.ndarray], masks: list[np.ndarray], shrink: float, centre) -> np.ndarray:
    """[S, J, 3] each source's ``centre`` (median or mean over its examples) of its ``values`` [n_s, J, 3]
    where its ``masks`` [n_s, J] say it has the joint, shrunk toward the mean of the sources' by ``shrink``
    examples' worth; each source counts once in that prior, however many examples it has."""
    S, J = len(values), values[0].shape[1]
    centres, counts = np.zeros((S, J, 3)), np.zeros((S, J))
    for c, (value, mask) in enumerate(zip(values, masks)):
        counts[c] = mask.sum(axis=0)
        for j in np.flatnonzero(counts[c]):
            centres[c, j] = centre(value[mask[:, j], j], axis=0)
    seen = counts > 0
    prior = np.einsum("cj,cja->ja", seen, centres) / np.maximum(seen.sum(axis=0), 1)[:, None]
    return (counts[..., None] * centres + shrink * prior) / (counts + shrink)[..., None]


def default_convention(conventions: dict, asked: str | None) -> str:
    """The convention a learned template rigs in unless told: ``asked``, else the one most examples follow
    (a studio learning from its own rigs gets its own)."""
    if asked is not None:
        return asked
    return Counter({name: c["examples"] for name, c in conventions.items()}).most_common(1)[0][0]


def _family_mean(offsets: dict[str, np.ndarray]) -> np.ndarray:
    """[J, 3] the mean of the sources' ``offsets`` {source: [J, 3]}: each family's (``source_family``) mean
    first, then the mean of the families'."""
    families: dict[str, list[np.ndarray]] = {}
    for source, value in offsets.items():
        families.setdefault(source_family(source), []).append(value)
    return np.mean([np.mean(values, axis=0) for values in families.values()], axis=0)


def _symmetric(offsets: np.ndarray, template) -> np.ndarray:
    """[J, 3] with each mirror pair's offsets averaged: the frames are mirrored already
    (``convention.joint_frames``), so a left joint and its right twin take the same numbers."""
    out = offsets.copy()
    for i, j in template.symmetry:
        out[i] = out[j] = (offsets[i] + offsets[j]) / 2
    return out
