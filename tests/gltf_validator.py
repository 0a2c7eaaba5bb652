"""The Khronos glTF validator (npm ``gltf-validator``, installed by .ci/run into .ci/node) for the tests."""
from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

VALIDATOR = Path(__file__).with_name("validate_gltf.js")


def validate(path: Path) -> dict:
    """The validator's summary for ``path``; skips the test when node or gltf-validator is missing."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    run = subprocess.run([node, str(VALIDATOR), str(path)], capture_output=True, text=True, timeout=120)
    if run.returncode == 2:
        pytest.skip("gltf-validator is not installed (npm install --prefix .ci/node gltf-validator)")
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)
