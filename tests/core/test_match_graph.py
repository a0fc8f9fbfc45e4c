from guided_sfm.core.match_graph import components, count_components

PAIRS = [(1, 2), (2, 3), (4, 5)]


def test_components_before_deletion():
    assert count_components(PAIRS) == 2
    assert components(PAIRS) == [{1, 2, 3}, {4, 5}]


def test_components_after_deletion_count_isolated_images():
    assert count_components(PAIRS, [(2, 3)]) == 3
    assert components(PAIRS, [(3, 2), (4, 5)]) == [{1, 2}, {3}, {4}, {5}]


def test_unknown_removed_pairs_are_ignored_and_empty_graph_has_none():
    assert count_components(PAIRS, [(7, 8)]) == 2
    assert count_components([]) == 0


def test_long_chain_is_fast_and_exact():
    chain = [(i, i + 1) for i in range(10_000)]
    assert count_components(chain) == 1
    assert count_components(chain, chain[::1000]) == 11
