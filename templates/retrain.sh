#!/usr/bin/env bash
# Retrain the built-in templates from the corpus: the one command the README documents.
#   bash templates/retrain.sh [SHARED]      (SHARED defaults to ../shared, beside the checkout)
# Each is learned by `autorig learn` from the 0 A.D. corpus (shared/data/train) and the shared artists' rigs
# (shared/data/rigged) whose joints.json maps the template's joints, on the hand-set template of the same name
# (templates/handset/: joint names, mirror pairs, feet, fat joints, the prior for the penalty weights).
set -euo pipefail
cd "$(dirname "$0")/.."
SHARED="${1:-../shared}"
# What each learns is what rigged unseen corpus groups better (benchmarks/cross_validation.py). The biped learns
# all but the head/tail cue's weight (the cue is for a head on a neck; it turned bipeds round). The four-legged
# templates keep their hand-set proportions and penalty weights (the learned ones rigged worse: mean joint error
# 14.5 % against 11.8 %) and learn the head/tail cue's weight, the placement (10.3 %) and their confidence.
learn() {
    autorig learn "$SHARED/data/train" "$SHARED/data/rigged" --template "templates/handset/$1.json" \
        --name "$1" -o "templates/$1.json" --learn "$2"
}
learn biped proportions,penalties,placement,confidence
learn quadruped orientation,placement,confidence
learn horse orientation,placement,confidence
