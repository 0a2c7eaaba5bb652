#!/usr/bin/env bash
# Retrain the built-in templates from the corpus: the one command the README documents.
#   bash templates/retrain.sh [SHARED]      (SHARED defaults to ../shared, beside the checkout)
# Each is learned by `autorig learn` from the 0 A.D. corpus (shared/data/train) and the shared artists' rigs
# (shared/data/rigged) whose joints.json maps the template's joints, on the hand-set template of the same name
# (templates/handset/: joint names, mirror pairs, feet, fat joints, the prior for the penalty weights).
set -euo pipefail
cd "$(dirname "$0")/.."
SHARED="${1:-../shared}"
for name in biped quadruped horse; do
    autorig learn "$SHARED/data/train" "$SHARED/data/rigged" --template "templates/handset/$name.json" \
        --name "$name" -o "templates/$name.json"
done
