"""A batch killed (SIGKILL, the whole process group: the batch and its workers) at seeded random moments (while
it starts, then after a seeded number of outputs) and run again ends exactly as a batch never interrupted: the
same output files, byte for byte, the same report (an asset rigged before the kill reported skipped, previously
ok), no temporaries left. Two batches on one output folder at once: the second refuses with one line, exit 4
(issue 28)."""
from __future__ import annotations

import hashlib
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from autorig.cli import cli

KILLS = 5
SEED = 28
SKELETON = {"joints": [{"name": "hips", "parent": None, "position": [0, 0.5, 0]},
                       {"name": "head", "parent": "hips", "position": [0, 0.9, 0]},
                       {"name": "left_knee", "parent": "hips", "position": [0.08, 0.27, 0]},
                       {"name": "right_knee", "parent": "hips", "position": [-0.08, 0.27, 0]}]}

pytestmark = pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")


@pytest.fixture(scope="module")
def assets(tmp_path_factory) -> Path:
    """12 small mannequins (OBJ, OFF, three sizes, two folders), one broken file, and a skeleton."""
    from autorig.samples import mannequin

    root = tmp_path_factory.mktemp("crash")
    sample = mannequin(resolution=24)
    for k in range(12):
        folder = root / "in" / ("a" if k % 2 else "b")
        folder.mkdir(parents=True, exist_ok=True)
        vertices = sample.vertices * (1 + k / 10) + k
        if k % 3:
            lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
            lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in sample.faces]
            (folder / f"man{k}.obj").write_text("\n".join(lines) + "\n")
        else:
            (folder / f"man{k}.off").write_text(
                f"OFF\n{len(vertices)} {len(sample.faces)} 0\n" + "".join(f"{x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in
                                                                      vertices)
                + "".join(f"3 {a} {b} {c}\n" for a, b, c in sample.faces))
    (root / "in" / "broken.obj").write_text("v 0 0 0\nf 1 2 3\n")
    (root / "skeleton.json").write_text(json.dumps(SKELETON))
    return root


def batch(root: Path, out: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "autorig.cli", "batch", str(root / "in"), "-o", str(root / out),
                             "--skeleton", str(root / "skeleton.json"), "-j", "2", "-q",
                             "--report", str(root / out / "report.json")],
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def files_of(out: Path) -> dict[str, str]:
    """{relative path: SHA-256} of every file in the output folder but the report, manifest and lock."""
    return {p.relative_to(out).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(out.rglob("*"))
            if p.is_file() and p.name not in ("report.json", ".autorig-batch.json", ".autorig-batch.lock")}


def report_of(out: Path) -> dict:
    """The report with what differs between any two runs taken out: times, and skipped-because-done."""
    report = json.loads((out / "report.json").read_text())
    assets = []
    for asset in report["assets"]:
        asset = {k: v for k, v in asset.items() if k not in ("seconds", "timings", "previous_timings")}
        if asset["status"] == "skipped":
            asset["status"] = asset.pop("previous")
        else:
            asset.pop("previous")
        assets.append(asset)
    return {"assets": assets, "exit_code": report["summary"]["exit_code"], "total": report["summary"]["total"]}


@pytest.fixture(scope="module")
def reference(assets) -> tuple[dict, dict, float]:
    """The uninterrupted run: its files' hashes, its report, its seconds."""
    started = time.perf_counter()
    run = batch(assets, "reference")
    assert run.wait(timeout=300) == 7, run.stderr.read()
    return files_of(assets / "reference"), report_of(assets / "reference"), time.perf_counter() - started


def rigged(out: Path) -> int:
    """Outputs in place (a temporary is hidden, and renamed into place whole)."""
    return len(list(out.rglob("*.rigged.glb")))


def test_killed_and_resumed_gives_the_uninterrupted_outputs_and_report(assets, reference):
    expected_files, expected_report, seconds = reference
    assert len(expected_files) == 12 and expected_report["exit_code"] == 7
    moments = random.Random(SEED)
    # The first kill lands while the batch starts (plan, workers spawning), the others once a seeded number of
    # outputs are in place, a few milliseconds later: mid-rig or mid-write, with work still left each time.
    after_outputs = [0] + sorted(moments.sample(range(1, len(expected_files)), KILLS - 1))
    killed_mid_run = 0
    for target in after_outputs:
        run = batch(assets, "resumed")
        if target == 0:
            time.sleep(moments.uniform(0.05, 0.3) * seconds)
        else:
            while rigged(assets / "resumed") < target and run.poll() is None:
                time.sleep(0.005)
            time.sleep(moments.uniform(0, 0.05))
        killed_mid_run += run.poll() is None
        try:
            os.killpg(run.pid, signal.SIGKILL)
        except ProcessLookupError:  # it had ended already: this kill did not count
            pass
        run.wait(timeout=60)
    final = batch(assets, "resumed")
    assert final.wait(timeout=300) == 7, final.stderr.read()

    assert killed_mid_run == KILLS, "every kill should land while the batch runs"
    assert files_of(assets / "resumed") == expected_files
    assert report_of(assets / "resumed") == expected_report
    assert not [p for p in (assets / "resumed").rglob("*.tmp")]


def _wait_until_gone(group: int, timeout: float = 30.0) -> None:
    """Wait until no live process of the process ``group`` is left (zombies have closed their files). The
    batch's worker processes, forked with the lock's descriptor, hold the flock too; SIGKILLed, they end a
    moment after the leader the test waited for (a CI run once started the next batch inside that moment)."""
    def alive() -> bool:
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue   # ended while we looked
            if int(fields[2]) == group and fields[0] != "Z":
                return True
        return False

    deadline = time.monotonic() + timeout
    while alive():
        assert time.monotonic() < deadline, f"processes of group {group} still running {timeout} s after SIGKILL"
        time.sleep(0.02)


def test_a_second_batch_on_the_same_output_folder_refuses(assets, reference):
    first = batch(assets, "locked")
    lock = assets / "locked" / ".autorig-batch.lock"
    try:
        deadline = time.monotonic() + 60
        while not (lock.exists() and lock.read_text().strip()) and first.poll() is None:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert first.poll() is None, "the first batch ended before the second started"
        second = CliRunner().invoke(cli, ["batch", str(assets / "in"), "-o", str(assets / "locked"),
                                          "--skeleton", str(assets / "skeleton.json")], prog_name="autorig")
        assert second.exit_code == 4
        [line] = second.stderr.splitlines()
        assert "another autorig batch is writing into it" in line and f"process {first.pid}" in line
    finally:
        os.killpg(first.pid, signal.SIGKILL)
        first.wait(timeout=60)
        _wait_until_gone(first.pid)
    # Killed, it holds the lock no more.
    third = CliRunner().invoke(cli, ["batch", str(assets / "in"), "-o", str(assets / "locked"), "-j", "1",
                                     "--skeleton", str(assets / "skeleton.json")], prog_name="autorig")
    assert third.exit_code == 7, third.stderr
    assert files_of(assets / "locked") == reference[0]
