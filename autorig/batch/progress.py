"""What ``autorig batch`` shows while it runs, on stderr.

On a terminal: a tqdm bar of the assets to rig, with done/total, the ok and failed counts, how many are left and
an ETA; failed assets are printed above it as they end. tqdm rather than rich: it does exactly this, has no
dependencies of its own, and is small and long maintained.

Not on a terminal (CI logs, pipes): no bar, whose redraws make a log unreadable, but one line per asset as it
ends, so a log shows which asset was slow or failed and that the batch is alive::

    [3/12] ok      dogs/rex.obj  quadruped  3.1 s  confidence 0.82
    [4/12] failed  props/lamp.obj: the mesh is flat (...)
    [5/12] doubtful dogs/cow.obj  biped  2.1 s  confidence 0.05, probably wrong (left toe / right toe: ...)

A doubtful rig (``AssetResult.doubtful``: confidence below 0.5) is rigged, but probably wrong: its line says
so, with what pulled its confidence down (``autorig.explain``).

Assets skipped as unchanged are summed up in one line, except earlier failures, which are listed again.
``quiet`` keeps only the lines of failed and doubtful assets.
"""
from __future__ import annotations

import sys

from .result import AssetResult


class BatchProgress:
    """``on_start`` and ``on_result`` callbacks for ``rig_folder`` that report on ``stream``."""

    def __init__(self, quiet: bool = False, stream=None):
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.total = self.done = self.ok = self.failed = 0
        self.bar = None

    def on_start(self, todo: int, skipped: int) -> None:
        self.total = todo
        if skipped and not self.quiet:
            self._line(f"{skipped} asset{'s' * (skipped != 1)} unchanged since the last run: skipped "
                       f"(--force rigs them again)")
        if todo and not self.quiet and _is_terminal(self.stream):
            from tqdm import tqdm
            self.bar = tqdm(total=todo, file=self.stream, unit="asset", dynamic_ncols=True, desc="rigging",
                            bar_format="{desc} {n_fmt}/{total_fmt} |{bar}| [{elapsed}<{remaining}{postfix}]")
            self._postfix()

    def on_result(self, asset: AssetResult) -> None:
        if asset.status == "skipped":
            if asset.failed:
                self._line(f"failed  {asset.error} (unchanged since)")
            elif asset.doubtful:    # said even when quiet: a warning
                self._line(f"doubtful {asset.input}  confidence {asset.confidence:.2f} (unchanged since)")
            return
        self.done += 1
        if asset.status == "ok":
            self.ok += 1
        else:
            self.failed += 1
        if self.bar is not None:
            if asset.failed:
                self._line(f"failed  {asset.error}")
            elif asset.doubtful:
                self._line(f"doubtful {asset.input}  confidence {asset.confidence:.2f}, probably wrong")
            self.bar.update(1)
            self._postfix()
        elif asset.failed:
            self._line(f"[{self.done}/{self.total}] failed  {asset.error}")
        elif not self.quiet or asset.doubtful:
            confidence = f"  confidence {asset.confidence:.2f}" if asset.confidence is not None else ""
            if asset.doubtful:
                reasons = "; ".join(asset.confidence_reasons)
                confidence += ", probably wrong" + (f" ({reasons})" if reasons else "")
            self._line(f"[{self.done}/{self.total}] {'doubtful' if asset.doubtful else 'ok      '} {asset.input}  "
                       f"{asset.template}  {asset.seconds:.1f} s{confidence}")
        from ..input.confine import dropped_line
        for dropped in asset.dropped:  # said even when quiet, as by 'autorig MESH'
            self._line(f"warning {dropped_line(asset.input, dropped)}")

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def _postfix(self) -> None:
        self.bar.set_postfix_str(f"ok {self.ok}, failed {self.failed}, left {self.total - self.done}",
                                 refresh=True)

    def _line(self, text: str) -> None:
        from ..errors import printable
        text = printable(text)
        if self.bar is not None:
            self.bar.write(text, file=self.stream)
        else:
            print(text, file=self.stream, flush=True)


def _is_terminal(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
