"""DBG bitset algorithms against graphs whose answers are worked out by hand."""

from __future__ import annotations

import itertools
import random

from ndbg_cli.ndbg.dbg import DBG, bits, condensation, free_subsets, mask_of, strong_components


def brute_free(g: DBG, mask: int) -> set[int]:
    idx = list(bits(mask))
    out = set()
    for r in range(1, len(idx)):
        for combo in itertools.combinations(idx, r):
            s = mask_of(combo)
            if g.is_free(s, mask):
                out.add(s)
    return out


def test_chain_has_prefix_free_sets():
    # 0 -> 1 -> 2 -> 3 (each part blocked by the next): the free sets are the suffixes
    # {3}, {2,3}, {1,2,3}
    g = DBG.from_arcs(4, [(0, 1), (1, 2), (2, 3)])
    assert set(free_subsets(g)) == {0b1000, 0b1100, 0b1110}


def test_cycle_is_one_component_and_never_free():
    g = DBG.from_arcs(3, [(0, 1), (1, 2), (2, 0)])
    assert strong_components(g) == [0b111]
    assert list(free_subsets(g)) == []
    assert not g.is_acyclic()


def test_no_arcs_every_proper_subset_free():
    g = DBG.empty(4)
    assert len(list(free_subsets(g))) == 2**4 - 2


def test_induced_subgraph_ignores_outside_parts():
    # 0 -> 1 -> 2: inside {0, 1} only {1} is free; inside {0, 2} both singletons are free.
    g = DBG.from_arcs(3, [(0, 1), (1, 2)])
    assert set(free_subsets(g, 0b011)) == {0b010}
    assert set(free_subsets(g, 0b101)) == {0b001, 0b100}


def test_condensation_successors_come_first():
    g = DBG.from_arcs(5, [(0, 1), (1, 0), (1, 2), (2, 3), (3, 2), (4, 0)])
    comps, succ = condensation(g)
    pos = {c: k for k, c in enumerate(comps)}
    assert set(comps) == {0b00011, 0b01100, 0b10000}
    assert succ[pos[0b00011]] == 1 << pos[0b01100]
    for k, s in enumerate(succ):
        assert all(j < k for j in bits(s))


def test_free_subsets_match_brute_force_on_random_graphs():
    rng = random.Random(7)
    for _ in range(200):
        n = rng.randint(2, 7)
        arcs = [(i, j) for i in range(n) for j in range(n) if i != j and rng.random() < 0.25]
        g = DBG.from_arcs(n, arcs)
        mask = rng.randint(1, (1 << n) - 1)
        got = list(free_subsets(g, mask))
        assert len(got) == len(set(got))
        assert set(got) == brute_free(g, mask)


def test_closure_and_blockers():
    g = DBG.from_arcs(4, [(0, 1), (1, 2), (3, 0)])
    assert g.closure(0b0001) == 0b0111
    assert g.blockers(0b0001) == 0b0010
    assert g.reversed().succ[1] == 0b0001
