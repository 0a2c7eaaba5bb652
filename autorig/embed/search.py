"""A* search over partial embeddings of the reduced skeleton.

A state places the first m reduced joints (parents before children) on spheres. Its cost so far is the sum of
the penalties of the bones placed; its estimate of what is left is, for every joint not yet placed, the
cheapest its bone could possibly cost: given its parent's sphere when that is placed, otherwise over all
parent and child spheres. The penalties that depend on other bones (symmetry, backtrack, overlap) are >= 0
and left out of the estimate, so it never overestimates (admissible), and the first complete embedding taken
off the queue is the optimal one.
"""
from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np

from ..errors import RigFailedError
from ..input.budget import SEARCH_QUEUE, checkpoint, over_memory
from .penalties import EmbeddingProblem, backtrack_penalty, overlap_penalty, symmetry_penalty


@dataclass
class Embedding:
    """spheres [K] sphere of each reduced joint; paths [K] sphere paths of each reduced bone, parent to joint
    (the root's is just its sphere); cost the total penalty; expanded number of states taken off the queue;
    bound: no embedding costs less (the cost itself when optimal; the search frontier's when out of budget);
    swapped: the reduced joints that ``autorig.embed.swap_mirrored`` gave their mirror image's sphere (empty: none)."""
    spheres: np.ndarray
    paths: list[list[int]]
    cost: float
    expanded: int
    optimal: bool = True
    bound: float | None = None
    swapped: tuple[int, ...] = ()     # reduced joints given their mirror image's sphere (``embed.swap_mirrored``)

    def __post_init__(self):
        if self.bound is None:
            self.bound = float(self.cost)


GREEDY_STARTS = 8
# States the rig's search may take off the queue before settling for the greedy embedding. Over the 112 shared
# and corpus characters, discretized whole, the optimum is found within 2,700 expansions (a stag), except on the
# whole 97k-face CyberWare horse (meshes/horse.obj, axes given): 10,900 with the quadruped, 48,600 with the
# horse template, where the greedy descents end at 16.4 and 14.8 against optima of 4.3 and 6.5, legs in the
# wrong legs. A search that runs out is otherwise one lost in a shape the template does not fit (a biped with
# the quadruped: ~3 s to 60,000, then the greedy answer, confidence 0). The orientation's searches, which rank
# many frames, keep their own smaller budget (``orient.DECISION_EXPANSIONS``).
MAX_EXPANSIONS = 60_000
QUEUED_BYTES = 250     # about what one queued partial embedding takes (a tuple of floats and sphere indices)


def search(problem: EmbeddingProblem, max_expansions: int = MAX_EXPANSIONS) -> Embedding:
    K = len(problem.reduced.joints)
    parents = problem.reduced.parents
    children = [[c for c in range(K) if parents[c] == k] for k in range(K)]
    # Cheapest cost of bone k given its parent's sphere ([S]), and with nothing placed (scalar).
    S = len(problem.graph.radii)
    best_given_parent = [None]
    for k in range(1, K):
        best = np.full(S, np.inf)
        rows = problem.bone_row[k] >= 0
        if problem.bone_cost[k].size:
            best[rows] = np.min(problem.bone_cost[k], axis=1)[problem.bone_row[k][rows]]
        best_given_parent.append(best)
    best_anywhere = np.array([0.0] + [float(np.min(best_given_parent[k])) for k in range(1, K)])
    if not np.all(np.isfinite(best_anywhere)) or not np.isfinite(problem.root_cost).any():
        raise RigFailedError("the template does not fit this shape: some joint has no place to go "
                             "(too few limbs or extremities in the mesh)")

    # Spheres on the paths of each expanded state's bones, built from its parent state's.
    used_by_state: dict[tuple[int, ...], np.ndarray] = {(): np.zeros(S, dtype=bool)}

    def estimate(placed: tuple[int, ...]) -> float:
        m = len(placed)
        total = 0.0
        for k in range(m, K):
            p = parents[k]
            total += best_given_parent[k][placed[p]] if p < m else best_anywhere[k]
        return total

    def expand(placed: tuple[int, ...], g: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Spheres [N] the next joint can take, with the cost so far [N] and the estimate of the total [N]."""
        k = len(placed)
        p = parents[k]
        u = placed[p]
        used = used_by_state[placed[:-1]].copy()
        if k > 1:
            used[problem.graph.path(placed[parents[k - 1]], placed[k - 1])] = True
        used_by_state[placed] = used
        candidates = problem.candidates[k]
        row = problem.bone_row[k][u]
        cost = problem.bone_cost[k][row].copy() if row >= 0 else np.full(len(candidates), np.inf)
        taken = np.zeros(S, dtype=bool)
        taken[list(placed)] = True
        cost[taken[candidates]] = np.inf
        grandparent = parents[p]
        if grandparent >= 0:
            cost += backtrack_penalty(problem, k, placed[grandparent], u, candidates)
        mirror = problem.mirror[k]
        if 0 <= mirror < k:
            cost += symmetry_penalty(problem, k, u, candidates, placed[mirror], placed[parents[mirror]])
        if k > 1:
            here = used & (problem.graph.distances[u] > problem.shared_ok[k])
            cost += overlap_penalty(problem, k, u, here, candidates)
        # The estimate for the joints after k: tight for those whose parent is placed (k's children
        # among them, per candidate sphere), loose for the others.
        later = sum(best_given_parent[j][placed[parents[j]]] if parents[j] < k else best_anywhere[j]
                    for j in range(k + 1, K) if parents[j] != k)
        bound = later + sum((best_given_parent[c][candidates] for c in children[k]), np.zeros(len(candidates)))
        g2 = g + cost
        keep = np.isfinite(g2) & np.isfinite(bound)
        return candidates[keep], g2[keep], (g2 + bound)[keep]

    # Greedy descents from the most promising roots give complete embeddings; the cheapest bounds the
    # search from above, so states that cannot beat it are never queued.
    upper, greedy = np.inf, None
    roots = np.flatnonzero(np.isfinite(problem.root_cost))
    root_f = np.array([problem.root_cost[s] + estimate((int(s),)) for s in roots])
    for s in roots[np.argsort(root_f, kind="stable")[:GREEDY_STARTS]]:
        placed, g = (int(s),), float(problem.root_cost[s])
        while len(placed) < K:
            checkpoint()
            spheres, g2, f2 = expand(placed, g)
            if len(spheres) == 0:
                break
            best = int(np.argmin(f2))
            placed, g = placed + (int(spheres[best]),), float(g2[best])
        if len(placed) == K and g * (1 + 1e-9) + 1e-12 < upper:
            upper, greedy = g * (1 + 1e-9) + 1e-12, (placed, g)

    counter = 0
    queue = []
    for s in np.flatnonzero(np.isfinite(problem.root_cost)):
        g = float(problem.root_cost[s])
        placed = (int(s),)
        f = g + estimate(placed)
        if f <= upper:
            heapq.heappush(queue, (f, counter, g, placed))
            counter += 1

    expanded = 0
    frontier = 0.0    # the queue pops in order of f, an underestimate of any completion: a lower bound
    while queue:
        f, _, g, placed = heapq.heappop(queue)
        frontier = f
        if len(placed) == K:
            return Embedding(np.array(placed), _paths(problem, placed), g, expanded)
        expanded += 1
        if expanded > max_expansions:
            break
        checkpoint()
        spheres, g2, f2 = expand(placed, g)
        for i in np.flatnonzero(f2 <= upper):
            heapq.heappush(queue, (float(f2[i]), counter, float(g2[i]), placed + (int(spheres[i]),)))
            counter += 1
        if len(queue) > SEARCH_QUEUE:
            over_memory("the embedding's search", len(queue) * QUEUED_BYTES, SEARCH_QUEUE * QUEUED_BYTES,
                        f"{len(queue):,} partial embeddings")
    if greedy is not None:
        # Out of budget: the greedy embedding is complete and usually close; the caller is told.
        return Embedding(np.array(greedy[0]), _paths(problem, greedy[0]), greedy[1], expanded, optimal=False,
                         bound=min(frontier, greedy[1]))
    raise RigFailedError("the template could not be embedded in this shape: no placement of its joints "
                         "keeps every limb inside the mesh")


def _paths(problem: EmbeddingProblem, placed: tuple[int, ...]) -> list[list[int]]:
    parents = problem.reduced.parents
    out = [[placed[0]]]
    for k in range(1, len(placed)):
        out.append(problem.graph.path(placed[parents[k]], placed[k]))
    return out
