"""Connected components of the match graph (images joined by verified pairs)."""

from __future__ import annotations

from collections.abc import Iterable

from guided_sfm.core.types import PairKey, pair_key


class _UnionFind:
    def __init__(self, nodes: Iterable[int]) -> None:
        self.parent = {node: node for node in nodes}

    def find(self, node: int) -> int:
        root = node
        while self.parent[root] != root:
            root = self.parent[root]
        while self.parent[node] != root:  # path compression keeps later finds flat
            self.parent[node], node = root, self.parent[node]
        return root

    def union(self, a: int, b: int) -> None:
        root_a, root_b = self.find(a), self.find(b)
        if root_a != root_b:
            self.parent[max(root_a, root_b)] = min(root_a, root_b)


def components(pairs: Iterable[PairKey], deleted: Iterable[PairKey] = ()) -> list[set[int]]:
    """Components (sets of image ids) after deleting pairs, over images paired before."""
    pairs = [pair_key(a, b) for a, b in pairs]
    deleted_keys = {pair_key(a, b) for a, b in deleted}
    forest = _UnionFind(image_id for pair in pairs for image_id in pair)
    for a, b in pairs:
        if (a, b) not in deleted_keys:
            forest.union(a, b)
    groups: dict[int, set[int]] = {}
    for node in forest.parent:
        groups.setdefault(forest.find(node), set()).add(node)
    return sorted(groups.values(), key=lambda group: (-len(group), min(group)))


def count_components(pairs: Iterable[PairKey], deleted: Iterable[PairKey] = ()) -> int:
    """Number of components after deleting pairs; images left with no pair count as one each."""
    return len(components(pairs, deleted))
