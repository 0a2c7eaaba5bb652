"""Time and memory budgets of the two stages whose work a small but pathological input can blow up past what
its size says: the embedding's A* search (the orientation's searches in every candidate frame, then the
embedding's own) and the bone heat (planning which bones heat, then the weights). Past a budget the rig stops
with ``OverBudget``, a ``RigFailedError`` (exit 5, "could not rig: ..." naming the stage and the reason),
instead of taking minutes or gigabytes.

    with budget("the embedding's search", SEARCH_SECONDS):
        ... checkpoint() ...              # in the stage's loops: raises OverBudget past the budget

Time is the process's CPU time (``time.process_time``), so that a busy machine, which makes a real rig wait
for a core, does not make it fail. ``checkpoint`` is a no-op outside any ``budget`` (library calls of the
stages' functions are not limited).
"""
from __future__ import annotations

import time
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

from ..errors import RigFailedError

# CPU seconds of all the A* searches of one rig (orientation and embedding): a backstop, not the searches' limit.
# Their limit is their expansion caps (``search.MAX_EXPANSIONS``, ``orient.DECISION_EXPANSIONS``...) and the
# sphere cap (``limits.MAX_SPHERES``), which count work, not time, so that whether a rig finishes does not depend
# on the machine's speed or load. A search that runs to its cap takes 2.0-2.9 s of CPU (the shared horse,
# armadillo, octopus, beast and ogre with a template that does not fit them, 196-734 spheres) and a whole rig's
# searches at most 3.9 s on an idle machine; on a loaded one CPU time runs two to three times that, and at 10 s
# a walking wipf with its head low failed or not by the machine (2 and 1 of 186 posed animals in two runs). The
# hostile soups' searches take under 1 s (the 1,910-sphere one 0.7 s).
SEARCH_SECONDS = 60.0
# Partial embeddings the search may hold in its queue at once (~250 bytes each: ~1 GB). Those characters
# reach at most ~35,000 (a MakeHuman biped with the quadruped template).
SEARCH_QUEUE = 4_000_000
# CPU seconds of planning the bones (``--skeleton``) and solving their heat, plus as many per million input faces
# (``heat_seconds``). The rigged and corpus characters with their own skeletons need at most ~2.2 s of wall
# time at load 8 (53 joints on a MakeHuman); CesiumMan subdivided to 1M faces with its skeleton, 26 s of CPU
# for the whole run (its bones' plan is the long part); a 1,000-joint skeleton of random joints in a
# 2,000-triangle soup took 157 s (132 s planning which bones heat).
HEAT_SECONDS = 10.0
HEAT_SECONDS_PER_MILLION_FACES = 60.0
# Memory of the skin weights' dense arrays (vertices x bones, a few of them at once): the 1M-face mannequin's
# are ~0.5 GB.
HEAT_BYTES = 6 << 30


def heat_seconds(faces: int) -> float:
    """The bone heat's budget in CPU seconds for a mesh of ``faces`` input triangles."""
    return HEAT_SECONDS + HEAT_SECONDS_PER_MILLION_FACES * faces / 1e6


class OverBudget(RigFailedError):
    """A stage ran past its time or memory budget (exit 5)."""


@dataclass(frozen=True)
class _Budget:
    stage: str
    seconds: float
    end: float


_ACTIVE: ContextVar[tuple[_Budget, ...]] = ContextVar("autorig_budgets", default=())


@contextmanager
def budget(stage: str, seconds: float):
    """Within the block, ``checkpoint()`` raises ``OverBudget`` once ``seconds`` of CPU time have passed since
    it began; ``stage`` names the work in the message ("the embedding's search")."""
    token = _ACTIVE.set(_ACTIVE.get() + (_Budget(stage, seconds, time.process_time() + seconds),))
    try:
        yield
    finally:
        _ACTIVE.reset(token)


def checkpoint() -> None:
    """Raise ``OverBudget`` if a budget in force has run out (cheap: call it once per loop round)."""
    active = _ACTIVE.get()
    if not active:
        return
    now = time.process_time()
    for spent in active:
        if now > spent.end:
            raise OverBudget(f"could not rig: {spent.stage} took more than its {spent.seconds:.3g} s of CPU (a "
                             f"character needs a few at most): the shape or skeleton is not one this stage "
                             f"can resolve")


def over_memory(stage: str, needed: int, limit: int, what: str) -> None:
    """Raise ``OverBudget`` when ``stage`` would need ``needed`` bytes (for ``what``), more than ``limit`` or than
    the memory available."""
    from .limits import available_memory
    available = available_memory()
    cap = limit if available is None else min(limit, available)
    if needed > cap:
        raise OverBudget(f"could not rig: {stage} would need {needed / 2**30:.1f} GB for {what}, more than "
                         f"{'its budget' if cap == limit else 'the memory available'} ({cap / 2**30:.1f} GB)")
