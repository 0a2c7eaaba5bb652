"""The sphere graph's contacts between separate pieces of the mesh (``autorig.discretize.graph._piece_contacts``):
an edge that joins a piece where nothing joins it yet is kept, so is one whose spheres are joined nearby
anyway, and one that closes a loop through the body is cut."""
from __future__ import annotations

import numpy as np

from autorig.discretize.graph import LOOP, _piece_contacts

CHAINS = [(1, 2), (2, 3), (3, 4), (4, 5), (6, 7), (7, 8), (8, 9), (9, 10), (0, 11)]
BETWEEN = [(0, 1), (0, 6), (1, 11), (5, 10)]     # shoulders, a seam beside the left one, the hands


def arms_that_meet():
    """Centres and radii of a body with two arms on pieces of their own whose hands meet in front of it:
    sphere 0 the widest (the chest), 1-5 the left arm from the shoulder to the hand, 6-10 the right arm,
    11 a body sphere beside the left shoulder."""
    left = [(0.1 + 0.02 * k, 0.8 - 0.06 * k, 0.04 * k) for k in range(5)]
    c = np.array([(0.0, 0.75, 0.0), *left, *[(-x, y, z) for x, y, z in left], (0.1, 0.75, -0.02)])
    c[5], c[10] = (0.01, 0.6, 0.2), (-0.01, 0.6, 0.2)      # the hands, in front of the chest, 0.02 apart
    r = np.full(len(c), 0.02)
    r[0] = 0.1
    return c, r


def contacts_of(edges, between):
    c, r = arms_that_meet()
    pairs = np.array(edges)
    index = np.array([edges.index(e) for e in between])
    return {edges[e] for e in _piece_contacts(c, r, pairs, index, np.zeros(len(pairs), dtype=bool))}


def test_hands_of_two_arm_pieces_that_meet_are_cut_apart_and_the_shoulders_and_seam_kept():
    assert contacts_of(CHAINS + BETWEEN, BETWEEN) == {(5, 10)}
    c, _ = arms_that_meet()
    length = {e: float(np.linalg.norm(c[e[0]] - c[e[1]])) for e in CHAINS + BETWEEN}
    seam = length[(0, 1)] + length[(0, 11)] + length[(1, 11)]                  # the loop the seam closes
    hands = sum(length[e] for e in CHAINS[:8]) + length[(0, 1)] + length[(0, 6)]   # the one the hands close
    assert seam < LOOP < hands


def test_a_piece_joined_only_where_its_hand_meets_the_other_keeps_that_edge():
    """Without its shoulder's edge the right arm touches the rest only at the hands: there it is attached."""
    between = [e for e in BETWEEN if e != (0, 6)]
    assert contacts_of(CHAINS + between, between) == set()


def test_the_order_of_the_edges_does_not_change_what_is_cut():
    edges = CHAINS + BETWEEN
    assert contacts_of(edges[::-1], BETWEEN[::-1]) == {(5, 10)}
