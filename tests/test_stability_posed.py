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


BEAR = ROOT.parent / "shared" / "data" / "train" / "0ad_bear_polar"


@pytest.mark.skipif(not BEAR.exists(), reason="shared data (../shared/data) is not present")
def test_a_posed_animal_rigged_twice_from_the_same_arrays_gets_the_same_rig(tmp_path):
    """``--animal-poses``: the four-legged animals re-posed as ``benchmarks/animal_poses.py`` poses them (a pose's
    own comma inside it), each measured like a character at rest; an unknown pose is an error."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import stability
    out = tmp_path / "rows.json"
    name = "0ad_bear_polar (walk, head low)"
    assert stability.main(["--animal-poses", "walk, head low", "--only", "0ad_bear_polar", "--variants", "same",
                           "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert list(rows) == [name]
    (same,) = rows[name]
    assert same["variant"] == "same" and same["move"] == 0.0 and "not bit-identical" not in same["joint"]
    with pytest.raises(SystemExit):
        stability.main(["--animal-poses", "cartwheel"])


MOVED = [ROOT.parent / "shared" / "data" / "train" / name for name in ("0ad_aurochs", "0ad_fox")]


@pytest.mark.skipif(not all(p.exists() for p in MOVED), reason="shared data (../shared/data) is not present")
@pytest.mark.parametrize("animal, pose, seeds", [
    ("0ad_aurochs", "walk", 1),             # its mid-plane: one dip of the mirror error or another (0.59 %)
    ("0ad_aurochs", "walk, head low", 2),   # its head's end: one horn's tip, not the pair's middle (1.80 %)
    ("0ad_fox", "walk, head low", 1),       # a lifted hind leg's bend, one ring or another (its knee 1.61 %)
])
def test_a_posed_animal_re_exported_keeps_its_rig(tmp_path, animal, pose, seeds):
    """Every joint of a re-posed animal within 0.5 % of its height when its vertices move by 1e-6 of it (the
    issue's re-export), on three rigs whose joints had moved more (``stability.py --animal-poses``, 2fe4110)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import stability
    out = tmp_path / "rows.json"
    assert stability.main(["--animal-poses", pose, "--only", animal, "--variants", "noise", "--seeds", str(seeds),
                           "--json", str(out)]) == 0
    (rows,) = json.loads(out.read_text()).values()
    assert len(rows) == seeds and all(row["move"] <= 0.5 for row in rows), rows
