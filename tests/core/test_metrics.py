import numpy as np
import pytest

from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.geometry import rotation_angles_deg, rotation_from_qvec
from guided_sfm.core.metrics import (
    CameraError,
    Similarity,
    align_similarity,
    camera_errors,
    classify,
    evaluate,
    pruning_scores,
)

SIM = Similarity(2.5, rotation_from_qvec([0.9, 0.1, -0.3, 0.2]), np.array([3.0, -1.0, 0.5]))


def test_similarity_recovered_under_noise_and_30_percent_outliers():
    rng = np.random.default_rng(0)
    src = rng.uniform(-4, 4, size=(100, 3))
    dst = SIM.apply(src) + rng.normal(scale=0.01, size=(100, 3))
    outliers = rng.choice(100, 30, replace=False)
    dst[outliers] += rng.uniform(1, 5, size=(30, 3)) * rng.choice([-1, 1], size=(30, 3))
    sim = align_similarity(src, dst, threshold=0.15, seed=0)
    # tolerances: 0.5% scale, 0.2 deg, 3 cm (noise 1 cm on a 20 m wide set)
    assert sim.scale == pytest.approx(SIM.scale, rel=5e-3)
    assert rotation_angles_deg(sim.rotation, SIM.rotation) < 0.2
    np.testing.assert_allclose(sim.translation, SIM.translation, atol=0.03)
    expected = np.ones(100, dtype=bool)
    expected[outliers] = False
    np.testing.assert_array_equal(sim.inliers, expected)


def test_alignment_input_errors():
    with pytest.raises(InvalidInput, match="at least 3"):
        align_similarity(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(InvalidInput, match=r"\(N, 3\)"):
        align_similarity(np.zeros((4, 3)), np.zeros((5, 3)))


def _cameras(count: int, seed: int):
    rng = np.random.default_rng(seed)
    return {f"{i:02d}.png": (rotation_from_qvec(rng.normal(size=4)), rng.uniform(-5, 5, 3))
            for i in range(count)}


def _into_model(truth, sim: Similarity):
    """Truth cameras expressed in a model world that `sim` maps onto the truth."""
    rotation, scale, translation = sim.rotation, sim.scale, sim.translation
    return {n: (r @ rotation, rotation.T @ (c - translation) / scale)
            for n, (r, c) in truth.items()}


def test_camera_errors_vanish_for_a_similar_model_and_show_a_moved_camera():
    truth = _cameras(10, seed=1)
    est = _into_model(truth, SIM)
    rotation, center = est["03.png"]
    est["03.png"] = (rotation_from_qvec([np.cos(0.1), 0, 0, np.sin(0.1)]) @ rotation,
                     center + np.array([0.2, 0, 0]))
    sim = align_similarity(np.array([est[n][1] for n in sorted(est)]),
                           np.array([truth[n][1] for n in sorted(truth)]))
    errors = camera_errors(est, truth, sim)
    assert errors["00.png"].center < 1e-9 and errors["00.png"].rotation_deg < 1e-4
    assert errors["03.png"].center == pytest.approx(0.2 * SIM.scale)
    assert errors["03.png"].rotation_deg == pytest.approx(np.degrees(0.2))


def test_classify_thresholds():
    errors = {"a": CameraError(0.29, 9.9), "b": CameraError(0.31, 0.0), "c": CameraError(0.0, 10.1)}
    assert classify(errors) == {"a": False, "b": True, "c": True}


def test_evaluate_counts_fixed_still_wrong_broken_and_unregistered():
    truth = _cameras(12, seed=2)
    before_est = _into_model(truth, SIM)
    for name in ("01.png", "02.png"):
        before_est[name] = (before_est[name][0], before_est[name][1] + 1.0)
    before = evaluate(before_est, truth, num_models=2)
    assert before.wrong == ["01.png", "02.png"]
    assert before.still_wrong == before.wrong and before.fixed == []
    after_est = _into_model(truth, SIM)
    after_est["02.png"] = before_est["02.png"]
    after_est["05.png"] = (after_est["05.png"][0], after_est["05.png"][1] + 1.0)
    del after_est["07.png"]
    after = evaluate(after_est, truth, num_models=1, reference=before_est, before=before,
                     targets=before.wrong)
    assert (after.fixed, after.still_wrong, after.broken) == (["01.png"], ["02.png"], ["05.png"])
    assert after.unregistered == ["07.png"]
    offset = np.linalg.norm(np.ones(3)) * SIM.scale
    assert after.translation_mse == pytest.approx(offset**2 / 2)
    assert after.rotation_mae_deg == pytest.approx(0.0, abs=1e-4)
    report = after.to_dict()
    assert (report["num_fixed"], report["num_unregistered"], report["num_models"]) == (1, 1, 1)


@pytest.mark.parametrize(("deleted", "false", "expected"), [
    ({(1, 2), (2, 3)}, {(1, 2), (3, 4)}, (0.5, 0.5, 0.5)),
    ({(1, 2)}, {(1, 2), (3, 4)}, (1.0, 0.5, 2 / 3)),
    (set(), set(), (1.0, 1.0, 1.0)),
    (set(), {(1, 2)}, (1.0, 0.0, 0.0)),
    ({(1, 2)}, set(), (0.0, 1.0, 0.0)),
    ({(1, 2)}, {(3, 4)}, (0.0, 0.0, 0.0)),
])
def test_pruning_scores(deleted, false, expected):
    assert pruning_scores(deleted, false) == pytest.approx(expected)
