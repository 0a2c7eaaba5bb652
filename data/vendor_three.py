"""Make the copy of three.js that the review page's 3D view uses again, from npm, and check it byte for byte.

    python data/vendor_three.py            # fetch, check, build, write autorig/show/web/three-*.js and its licence
    python data/vendor_three.py --check    # the same, but only compare with the files in the package (exit 1 if not)

What is shipped (``autorig/show/web/``): ``three-0.187.0.min.js``, one classic script (not an ES module) that sets
``window.THREE`` to three.js 0.187.0 with ``GLTFLoader`` and ``OrbitControls`` from its examples, and
``three-LICENSE`` (three.js's MIT licence, from the same package). A classic script because the review page is
opened from disk: Chromium refuses ES modules and fetch() from file:// pages, but runs ``<script src>`` beside
them. The bundle is made by esbuild (``--bundle --format=iife --global-name=THREE --minify``) from the npm
tarballs, each checked against the sha256 pinned below, and the result against its own pin: the same inputs and
esbuild version give the same bytes. Needs ``npm`` (it only runs ``npm pack``, nothing is installed) and a
Linux x86-64 machine for esbuild's binary (elsewhere, pin your platform's ``@esbuild/*`` package: the bundle's
bytes do not depend on it, and its pin says so).
"""
from __future__ import annotations

import argparse
import hashlib
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
WEB = ROOT / "autorig" / "show" / "web"

THREE_VERSION = "0.187.0"
# npm package -> (version, sha256 of the tarball ``npm pack`` downloads)
PINS = {
    "three": (THREE_VERSION, "ff540832ded0cfe919764d24a3d88f3e2a05f23303f876423e4f893841e90728"),
    "@esbuild/linux-x64": ("0.28.2", "9573bb2233aab0f9ea7647d5cca9726113cc1768de61d66b17267f4db84488f6"),
}
BUNDLE = f"three-{THREE_VERSION}.min.js"
BUNDLE_SHA256 = "518705c22fa381fdebfd44957bbcb0929bfdeec5f7b9aabe617368465daf8720"
LICENSE = "three-LICENSE"
ENTRY = """export * from 'three';
export { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
export { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
"""


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def fetch(package: str, version: str, expected: str, into: Path) -> Path:
    """``npm pack package@version`` into ``into``, unpacked into ``into/package``; the tarball's sha256 checked."""
    name = subprocess.run(["npm", "pack", f"{package}@{version}", "--pack-destination", str(into), "--silent"],
                          check=True, capture_output=True, text=True).stdout.strip().splitlines()[-1]
    tarball = into / name
    if sha256(tarball) != expected:
        sys.exit(f"{package}@{version}: the tarball's sha256 is {sha256(tarball)}, not the pinned {expected}")
    target = into / "node_modules" / package
    target.mkdir(parents=True)
    with tarfile.open(tarball) as archive:
        archive.extractall(into / "unpacked" / package, filter="data")
    (into / "unpacked" / package / "package").rename(target)
    return target


def build(scratch: Path) -> tuple[Path, Path]:
    """(the bundle, three's LICENSE) built in ``scratch``."""
    three = fetch("three", *PINS["three"], scratch)
    esbuild = fetch("@esbuild/linux-x64", *PINS["@esbuild/linux-x64"], scratch) / "bin" / "esbuild"
    (scratch / "entry.js").write_text(ENTRY)
    bundle = scratch / BUNDLE
    subprocess.run([str(esbuild), "entry.js", "--bundle", "--format=iife", "--global-name=THREE", "--minify",
                    "--log-level=warning", f"--outfile={bundle.name}"], check=True, cwd=scratch)
    if sha256(bundle) != BUNDLE_SHA256:
        sys.exit(f"the bundle's sha256 is {sha256(bundle)}, not the pinned {BUNDLE_SHA256}")
    return bundle, three / "LICENSE"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare with the shipped files, write nothing")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="autorig-three-") as scratch:
        made = build(Path(scratch))
        if args.check:
            differ = [p.name for p, shipped in zip(made, (WEB / BUNDLE, WEB / LICENSE))
                      if not shipped.is_file() or shipped.read_bytes() != p.read_bytes()]
            if differ:
                print(f"differ from the shipped copy: {', '.join(differ)}", file=sys.stderr)
                return 1
            print(f"{WEB / BUNDLE}: three.js {THREE_VERSION}, sha256 {BUNDLE_SHA256}: as built from npm")
            return 0
        WEB.mkdir(parents=True, exist_ok=True)
        for path, name in zip(made, (BUNDLE, LICENSE)):
            shutil.copyfile(path, WEB / name)
            print(f"wrote {WEB / name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
