"""What a batch reports: one ``AssetResult`` per asset, gathered in a ``BatchResult``."""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

EXIT_SOME_FAILED = 7  # some of the batch's assets failed (6 is rig --strict's low confidence)
EXIT_DOUBTFUL = 8     # --fail-on-doubtful: none failed, but some rigs are probably wrong (autorig.explain)


@dataclass
class AssetResult:
    """What happened to one asset.

    input       path relative to the input folder (``/``-separated)
    output      path of its output relative to the output folder
    status      ``ok`` (rigged now), ``failed`` (now) or ``skipped`` (unchanged since an earlier run)
    previous    for ``skipped``: ``ok`` or ``failed``, the outcome that is kept; else None
    template    name of the template used (``auto`` for the template-free skeleton), or ``skeleton FILE`` for
                the user's skeleton FILE (relative to the input folder when inside it)
    up, front   the axes the rig stands on: found when asked for "auto" (still "auto" for an asset without a
                rig); "" with a skeleton (they do not apply)
    error       the one-line error of a failure (also of a skipped earlier failure), naming the asset
    error_type  the error's class name (``InputError``, ``RigFailedError``, ...), else None
    confidence  ``rig.info["confidence"]`` when the pipeline reports one, else None
    confidence_parts  ``rig.info["confidence_parts"]``, what the confidence is the product of, else {}
    confidence_reasons  ``rig.info["confidence_reasons"]``: what pulled the confidence down most, in words
                (``autorig.explain``), also for skipped assets; else []
    seconds     wall time of the work on this asset, transfer included (0 when skipped)
    timings     {stage: seconds} of the pipeline and the ``write`` stage ({} when skipped)
    previous_timings  for ``skipped``: the ``timings`` of the run that rigged it, else {}
    dropped     [{"what", "path", "reason"}] the parts of its look left out (``rig.info["dropped"]``: a texture
                outside its folder, missing, not an image; see ``autorig.input.confine``), also for skipped assets
    hands       ``rig.info["hands"]``: which hands got fingers ({"left": "fingers", "right": "mitten"}) when
                fingers were asked for (``autorig.hands``), also for skipped assets; else {}
    rest_pose   ``rig.info["rest_pose"]``: the arms' pose the bind pose is in ("T", "A" or "arms down",
                ``autorig.readoff.rest_pose``), also for skipped assets; None for a rig without arms or no rig
    arm_angle   ``rig.info["arm_angle"]``: the arms' degrees below the horizontal that pose was read from, or None
    markers     the markers file the asset was rigged with (``hero.markers.json`` beside ``hero.obj``, relative
                to the input folder; ``autorig.markers``), also for skipped assets; else None
    thumbnails  {view: path} of its small pictures (WebP; "front" and "side", or "top" and one of those for a
                flat shape) relative to the output folder, when
                a run with ``html`` drew them (kept for skipped assets), else {}
    """
    input: str
    output: str
    status: str
    template: str
    up: str
    front: str
    previous: str | None = None
    error: str | None = None
    error_type: str | None = None
    confidence: float | None = None
    seconds: float = 0.0
    timings: dict[str, float] = field(default_factory=dict)
    confidence_parts: dict[str, float] = field(default_factory=dict)
    previous_timings: dict[str, float] = field(default_factory=dict)
    thumbnails: dict[str, str] = field(default_factory=dict)
    dropped: list[dict] = field(default_factory=list)
    hands: dict[str, str] = field(default_factory=dict)
    rest_pose: str | None = None
    arm_angle: float | None = None
    confidence_reasons: list[str] = field(default_factory=list)
    markers: str | None = None

    @property
    def failed(self) -> bool:
        """Whether the asset has no rig: it failed now, or failed before and is unchanged since."""
        return self.status == "failed" or self.previous == "failed"

    @property
    def doubtful(self) -> bool:
        """Whether the asset has a rig (made now or kept) that is probably wrong: its confidence below
        ``autorig.explain.DOUBTFUL``."""
        from ..explain import is_doubtful
        return not self.failed and is_doubtful(self.confidence)


@dataclass
class BatchResult:
    """The outcome of ``rig_folder``: one ``AssetResult`` per asset, in the order assets are found."""
    input_dir: Path
    output_dir: Path
    assets: list[AssetResult]
    seconds: float
    fail_on_doubtful: bool = False

    @property
    def counts(self) -> dict[str, int]:
        """{"ok": n, "failed": n, "skipped": n} by ``status``; "doubtful": the assets with a rig, made now or
        kept, that is probably wrong (counted within "ok" and "skipped"); "still_failing": the skipped ones
        whose kept outcome is a failure."""
        counts = Counter(a.status for a in self.assets)
        return {**{status: counts[status] for status in ("ok", "failed", "skipped")},
                "doubtful": sum(a.doubtful for a in self.assets),
                "still_failing": sum(a.status == "skipped" and a.failed for a in self.assets)}

    @property
    def exit_code(self) -> int:
        """0 when every asset has a rig, ``EXIT_SOME_FAILED`` when any has none (see ``AssetResult.failed``),
        and with ``fail_on_doubtful`` ``EXIT_DOUBTFUL`` when none failed but some rig is doubtful."""
        if any(a.failed for a in self.assets):
            return EXIT_SOME_FAILED
        return EXIT_DOUBTFUL if self.fail_on_doubtful and any(a.doubtful for a in self.assets) else 0
