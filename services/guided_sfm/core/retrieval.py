"""Retrieval pairs for large captures: a vocabulary tree built from the project's own SIFT
descriptors (nothing is downloaded), each image paired with the images it retrieves plus its
capture-order neighbours, and the end of the capture with its start (loop closure).

COLMAP's own vocabulary-tree matcher fetches a tree trained on other photographs from the
internet; this machine cannot reach it, and a tree from the capture itself is small, quick to
build and knows exactly the textures it must tell apart.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pycolmap

log = logging.getLogger(__name__)

TREE_FILE = "vocab_tree.bin"
# Descriptors the tree is trained on: an even sample of each image's, so a capture of 1,000
# images trains on about as many as one of 200 (k-means grows with points x words).
TRAIN_DESCRIPTORS, TRAIN_PER_IMAGE_MIN = 200_000, 64
# Visual words: one per ~64 training descriptors (faiss's k-means wants >= 39 points a word),
# within bounds. Retrieval only has to rank a capture's own few hundred images.
DESCRIPTORS_PER_WORD, WORD_BOUNDS = 64, (256, 4096)
# k-means and word assignment effort. COLMAP's 100 iterations x 3 rounds and 256 checks are for
# trees shared by many captures; on hall-120 (115 images) 10 x 1 and 64 checks trained in 9 s
# instead of 26 s (20 x 1, 256) and retrieved 91% of the same pairs (docs/engine.md).
KMEANS_ITERATIONS, KMEANS_ROUNDS, TREE_CHECKS = 10, 1, 64
# Images each image is paired with by retrieval (COLMAP's default of 100 is for shared trees
# over huge collections; a walk sees a place from about this many views).
RETRIEVAL_NEIGHBOURS = 20


def visual_words_for(num_descriptors: int) -> int:
    """The tree's number of visual words for a training set of this many descriptors."""
    words = num_descriptors // DESCRIPTORS_PER_WORD
    return int(min(max(words, WORD_BOUNDS[0]), WORD_BOUNDS[1]))


def _training_descriptors(database: Path) -> pycolmap.FeatureDescriptorsFloat:
    """An even, seeded sample of every image's descriptors, as the tree's float type."""
    db = pycolmap.Database.open(database)
    try:
        images = [image.image_id for image in db.read_all_images()]
        per_image = max(TRAIN_PER_IMAGE_MIN, TRAIN_DESCRIPTORS // max(1, len(images)))
        rng, parts, kind = np.random.default_rng(0), [], None
        for image_id in images:
            descriptors = db.read_descriptors(image_id)
            kind, data = descriptors.type, np.asarray(descriptors.to_float().data)
            if len(data) > per_image:
                data = data[np.sort(rng.choice(len(data), per_image, replace=False))]
            parts.append(data)
    finally:
        db.close()
    stacked = np.ascontiguousarray(np.concatenate(parts), dtype=np.float32)
    return pycolmap.FeatureDescriptorsFloat(kind, stacked)


def build_tree(database: Path, path: Path, num_threads: int = 2) -> Path:
    """Train a vocabulary tree on the database's descriptors and write it to path."""
    descriptors = _training_descriptors(database)
    options = pycolmap.VisualIndex.BuildOptions()
    options.num_visual_words = visual_words_for(descriptors.data.shape[0])
    options.num_iterations, options.num_rounds = KMEANS_ITERATIONS, KMEANS_ROUNDS
    options.num_checks = TREE_CHECKS
    options.num_threads = num_threads
    index = pycolmap.VisualIndex.create(descriptors.data.shape[1], 64)
    index.build(options, descriptors)
    path.parent.mkdir(parents=True, exist_ok=True)
    index.write(path)
    log.info("Built a vocabulary tree of %d words from %d descriptors.",
             index.num_visual_words(), descriptors.data.shape[0])
    return path


def retrieved_pairs(database: Path, tree: Path, neighbours: int = RETRIEVAL_NEIGHBOURS,
                    num_threads: int = 2) -> list[tuple[int, int]]:
    """(query, retrieved) image-id pairs: each image with the images the tree ranks nearest."""
    options = pycolmap.VocabTreePairingOptions()
    options.vocab_tree_path = tree
    options.num_images = neighbours + 1  # an image retrieves itself first
    options.num_threads = num_threads
    db = pycolmap.Database.open(database)
    try:
        return [(a, b) for a, b in pycolmap.VocabTreePairGenerator(options, db).all_pairs()
                if a != b]
    finally:
        db.close()


def order_pairs(image_ids: Sequence[int], overlap: int) -> list[tuple[int, int]]:
    """Capture-order neighbours within `overlap`, and loop closure: the last `overlap` images
    with the first ones (a walk that ends where it began, an orbit)."""
    pairs = [(a, b) for i, a in enumerate(image_ids) for b in image_ids[i + 1 : i + 1 + overlap]]
    if len(image_ids) > 2 * overlap:
        pairs += [(a, b) for a in image_ids[:overlap] for b in image_ids[-overlap:]]
    return pairs


def combine(image_ids: Sequence[int], *pair_lists: Sequence[tuple[int, int]]) -> list[tuple]:
    """The union of pair lists, each pair once, ordered by capture order (earlier image first)."""
    rank = {image_id: index for index, image_id in enumerate(image_ids)}
    unique = {tuple(sorted(pair, key=rank.__getitem__)) for pairs in pair_lists for pair in pairs
              if pair[0] != pair[1]}
    return sorted(unique, key=lambda pair: (rank[pair[0]], rank[pair[1]]))
