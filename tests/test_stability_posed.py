"""``benchmarks/stability.py --posed``: the biped examples re-posed as ``benchmarks/poses.py`` poses them, each
measured like a character at rest."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CARATACOS = ROOT.parent / "shared" / "data" / "train" / "0ad_brit_caratacos"


@pytest.mark.skipif(not CARATACOS.exists(), reason="shared data (../shared/data) is not present")
def test_a_posed_character_rigged_twice_from_the_same_arrays_gets_the_same_rig(tmp_path):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import stability
    out = tmp_path / "rows.json"
    assert stability.main(["--posed", "idle", "--only", "0ad_brit_caratacos (idle)", "--variants", "same",
                           "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert list(rows) == ["0ad_brit_caratacos (idle)"]
    (same,) = rows["0ad_brit_caratacos (idle)"]
    assert same["variant"] == "same" and same["move"] == 0.0 and "not bit-identical" not in same["joint"]
    with pytest.raises(SystemExit):
        stability.main(["--posed", "cartwheel"])
