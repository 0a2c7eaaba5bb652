"""The batch's reports for machines: JSON and JUnit XML (the page for people is ``autorig.batch.review``)."""
from __future__ import annotations

import json
import os
from dataclasses import asdict

from ..version import __version__
from .result import AssetResult, BatchResult


def write_json_report(result: BatchResult, path: str | os.PathLike) -> None:
    """Write ``result`` as JSON, atomically::

        {"autorig": "0.1.0", "input": "/abs/assets", "output": "/abs/rigged", "seconds": 12.5,
         "summary": {"total": 4, "ok": 2, "failed": 1, "skipped": 1, "doubtful": 1, "still_failing": 0,
                     "exit_code": 7},
         "assets": [{"input": "dogs/rex.obj", "output": "dogs/rex.rigged.glb", "status": "ok",
                     "previous": null, "template": "quadruped", "up": "y", "front": "z", "error": null,
                     "error_type": null, "confidence": 0.82, "seconds": 3.1, "timings": {"load": 0.1, ...},
                     "confidence_parts": {"fit": 0.9, ...}, "previous_timings": {}, "thumbnails": {},
                     "rest_pose": "A", "arm_angle": 41.5, "doubtful": false, "confidence_reasons": [],
                     "markers": "dogs/rex.markers.json"},
                    ...]}

``doubtful`` is true for a rig (made now or kept) whose confidence is below 0.5, probably wrong, and
``confidence_reasons`` says in words what pulled its confidence down (``autorig.explain``); the summary's
``doubtful`` counts them (within ``ok`` and ``skipped``) and ``still_failing`` the skipped assets whose kept
outcome is a failure.

    ``rest_pose`` and ``arm_angle`` are the rig's (``autorig.readoff.rest_pose``: "T", "A" or "arms down", and the
    arms' degrees below the horizontal), null for a rig without arms (a quadruped) and for an asset without a rig.
    ``markers``, only for an asset rigged with a markers file beside it (``autorig.markers``), names that file.
    """
    from ..exchange import write_file_atomic
    document = {"autorig": __version__, "input": str(result.input_dir.resolve()),
                "output": str(result.output_dir.resolve()), "seconds": round(result.seconds, 3),
                "summary": {"total": len(result.assets), **result.counts, "exit_code": result.exit_code},
                "assets": [_json_asset(a) for a in result.assets]}
    write_file_atomic(path, (json.dumps(document, indent=1) + "\n").encode())


def _json_asset(asset: AssetResult) -> dict:
    document = asdict(asset)
    if not document["hands"]:       # only rigs that were asked for fingers (autorig.hands) say which hands have them
        del document["hands"]
    if document["markers"] is None:  # only assets with a markers file beside them say so
        del document["markers"]
    document["doubtful"] = asset.doubtful
    document["seconds"] = round(asset.seconds, 3)
    document["timings"] = {stage: round(s, 4) for stage, s in asset.timings.items()}
    return document


def write_junit_report(result: BatchResult, path: str | os.PathLike) -> None:
    """Write ``result`` as JUnit XML, atomically: one testsuite, one testcase per asset (classname its folder,
    name its file), ``<failure>`` for an asset without a rig, ``<skipped>`` for an unchanged rigged asset. A
    doubtful rig's case says so in its output, and with ``fail_on_doubtful`` is a ``<failure>`` of type
    ``DoubtfulRig``; the suite's ``doubtful`` property counts them."""
    import xml.etree.ElementTree as ET

    from ..errors import printable
    from ..exchange import write_file_atomic

    failing = {id(a) for a in result.assets if a.failed or (result.fail_on_doubtful and a.doubtful)}
    failures = len(failing)
    skipped = sum(a.status == "skipped" and id(a) not in failing for a in result.assets)
    attributes = {"tests": str(len(result.assets)), "failures": str(failures), "errors": "0",
                  "skipped": str(skipped), "time": f"{result.seconds:.3f}"}
    suites = ET.Element("testsuites", {"name": "autorig batch", **attributes})
    suite = ET.SubElement(suites, "testsuite", {"name": f"autorig batch {result.input_dir.name}", **attributes})
    properties = ET.SubElement(suite, "properties")
    ET.SubElement(properties, "property", {"name": "doubtful", "value": str(result.counts["doubtful"])})
    for asset in result.assets:
        folder, _, name = asset.input.rpartition("/")
        case = ET.SubElement(suite, "testcase", {"classname": folder or ".", "name": name,
                                                 "time": f"{asset.seconds:.3f}"})
        if asset.failed:
            message = asset.error or "failed"
            if asset.status == "skipped":
                message += " (unchanged since the run that failed)"
            failure = ET.SubElement(case, "failure", {"message": message, "type": asset.error_type or "Error"})
            failure.text = message
        elif id(asset) in failing:
            message = f"{asset.input}: {_doubt(asset)}"
            failure = ET.SubElement(case, "failure", {"message": message, "type": "DoubtfulRig"})
            failure.text = message
        elif asset.status == "skipped":
            ET.SubElement(case, "skipped", {"message": "unchanged since the last run"})
        else:
            out = ET.SubElement(case, "system-out")
            out.text = f"{asset.template} -> {asset.output}" + (
                f", confidence {asset.confidence:.3f}" if asset.confidence is not None else "") + (
                f", rest pose {asset.rest_pose} ({round(asset.arm_angle) + 0:d} deg)" if asset.rest_pose else
                "") + (f", markers {asset.markers}" if asset.markers else "") + (
                f"; doubtful: {_doubt(asset)}" if asset.doubtful else "")
    for element in suites.iter():  # XML 1.0 holds no control characters but tab and newline, nor lone surrogates
        element.attrib = {key: printable(value) for key, value in element.attrib.items()}
        if element.text:
            element.text = printable(element.text)
    ET.indent(suites)
    write_file_atomic(path, ET.tostring(suites, encoding="utf-8", xml_declaration=True) + b"\n")


def _doubt(asset: AssetResult) -> str:
    """"confidence 0.05, probably wrong (left toe / right toe: ...)": why a doubtful rig is doubtful."""
    reasons = "; ".join(asset.confidence_reasons)
    return f"confidence {asset.confidence:.2f}, probably wrong" + (f" ({reasons})" if reasons else "")
