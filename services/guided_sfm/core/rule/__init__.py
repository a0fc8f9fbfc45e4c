"""The pruning rules (docs/pruning-rule.md): which verified pairs an edit set deletes.

`driver` runs a rule; the paper's is the frustum test alone (`frustum`); the default rule adds the
match-placement, relative-pose and relative-rotation tests on the pair's own matches (`evidence`),
with the user's placements turned into 3D motions (`motion`) and its knobs in `tolerances`.
"""
