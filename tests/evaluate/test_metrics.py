import numpy as np
import pytest

from deformsim.errors import UserError
from deformsim.evaluate.metrics import compute_metrics, confusion_matrix, roc_auc, wilson_interval


def test_metrics_match_hand_computed_values():
    y = [0, 0, 0, 1, 1, 1, 1, 0]
    prob = [0.1, 0.6, 0.4, 0.9, 0.5, 0.2, 0.3, 0.49]  # 0.5 sits on the threshold: predicted deformed
    m = compute_metrics(y, prob, threshold=0.5)
    # predictions 0 1 0 1 1 0 0 0 -> TN=3 FP=1 FN=2 TP=2
    assert m["confusion"]["matrix"] == [[3, 1], [2, 2]]
    assert m["confusion"]["rows"] == ["true intact", "true deformed"]
    assert m["accuracy"] == pytest.approx(5 / 8)
    assert m["precision"] == pytest.approx(2 / 3)
    assert m["recall"] == pytest.approx(1 / 2)
    assert m["f1"] == pytest.approx(4 / 7)
    assert (m["n"], m["n_deformed"]) == (8, 4)


def test_threshold_moves_predictions():
    m = compute_metrics([0, 1], [0.3, 0.6], threshold=0.7)
    assert m["confusion"]["matrix"] == [[1, 0], [1, 0]]
    assert m["accuracy"] == 0.5


def test_degenerate_no_positive_defines_zero():
    m = compute_metrics(np.zeros(3, int), [0.1, 0.2, 0.3])
    assert m["accuracy"] == 1.0
    assert (m["precision"], m["recall"], m["f1"]) == (0.0, 0.0, 0.0)
    assert m["confusion"]["matrix"] == [[3, 0], [0, 0]]


def test_all_wrong():
    m = compute_metrics([1, 1, 0], [0.0, 0.1, 1.0])
    assert m["confusion"]["matrix"] == [[0, 1], [2, 0]]
    assert (m["accuracy"], m["precision"], m["recall"], m["f1"]) == (0.0, 0.0, 0.0, 0.0)


def test_confusion_matrix_layout():
    assert confusion_matrix([0, 0, 1, 1, 1], [0, 1, 0, 1, 1]).tolist() == [[1, 1], [1, 2]]


@pytest.mark.parametrize(
    "y, prob, match",
    [([0, 2], [0.1, 0.2], r"\[2\]"), ([0, 1], [0.1, 1.5], "1.5"), ([0, 1], [0.1], "equally long"), ([], [], "no images")],
)
def test_bad_input_is_a_user_error(y, prob, match):
    with pytest.raises(UserError, match=match):
        compute_metrics(y, prob)


def test_wilson_interval_matches_the_textbook_values():
    assert wilson_interval(5, 10) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)  # never below 0 at the edge
    assert wilson_interval(0, 0) == (0.0, 1.0)


def test_intervals_hold_the_value_and_narrow_with_more_photos():
    rng = np.random.default_rng(1)
    y = rng.integers(0, 2, 400)
    prob = np.clip(y * 0.5 + rng.uniform(0, 0.6, 400), 0, 1)
    small, big = compute_metrics(y[:40], prob[:40]), compute_metrics(y, prob)
    keys = ("accuracy", "f1", "precision", "recall")
    for m in (small, big):
        for k in keys:
            lo, hi = m["interval"][k]
            assert lo <= m[k] <= hi
    width = {k: [m["interval"][k][1] - m["interval"][k][0] for m in (small, big)] for k in keys}
    assert all(w_big < w_small / 2 for w_small, w_big in width.values())


def test_a_perfect_score_on_few_images_keeps_a_wide_interval():
    """8 photos all right: a percentile bootstrap of F1 gave 100.0-100.0 beside accuracy's 67.6-100."""
    m = compute_metrics([0, 1] * 4, [0.1, 0.9] * 4)
    assert m["interval"]["accuracy"] == pytest.approx((0.6756, 1.0), abs=1e-4)
    for k in ("f1", "precision", "recall"):  # 4 true positives, nothing wrong
        assert m["interval"][k] == pytest.approx(wilson_interval(4, 4)) and m["interval"][k][0] < 0.55
    (tn, fp), (fn, tp) = compute_metrics([0, 1, 1, 1, 0, 0], [0.9, 0.9, 0.9, 0.1, 0.1, 0.1])["confusion"]["matrix"]
    assert (tp, fp, fn) == (2, 1, 1)
    f1 = compute_metrics([0, 1, 1, 1, 0, 0], [0.9, 0.9, 0.9, 0.1, 0.1, 0.1])["interval"]["f1"]
    assert f1 == pytest.approx(wilson_interval(2, 3))  # F1 = TP / (TP + (FP + FN) / 2) = 2 / 3


def test_chance_accuracy_has_an_interval_over_the_baseline():
    m = compute_metrics([0, 1] * 5, [0.9, 0.1] * 2 + [0.1, 0.9] * 3)  # 6 of 10 right, baseline 0.5
    lo, hi = m["interval"]["accuracy"]
    assert lo < 0.5 < hi


def test_undefined_ratios_are_named():
    assert compute_metrics(np.zeros(3, int), [0.1, 0.2, 0.3])["undefined"] == ["precision", "recall", "f1"]
    none_predicted = compute_metrics([0, 1], [0.1, 0.2])
    assert none_predicted["undefined"] == ["precision"] and none_predicted["interval"]["f1"][0] == 0.0
    assert none_predicted["interval"]["precision"] is None
    assert compute_metrics([0, 1], [0.1, 0.9])["undefined"] == []
    assert compute_metrics(np.zeros(3, int), [0.1, 0.2, 0.3])["interval"]["f1"] is None


def test_auc_ranks_whatever_the_threshold():
    y = np.array([0, 0, 1, 1])
    # every deformed image above every intact one, though all sit below the threshold: accuracy 0.5, AUC 1
    m = compute_metrics(y, [0.1, 0.2, 0.3, 0.4])
    assert m["accuracy"] == 0.5 and m["auc"] == 1.0
    # by hand, pairs (deformed, intact): 0.3 > 0.1, 0.3 = 0.3 (half), 0.2 > 0.1, 0.2 < 0.3 -> 2.5 of 4
    rows = np.array([[0.1, 0.3, 0.3, 0.2], [0.9, 0.8, 0.1, 0.2]])
    assert roc_auc(rows, y == 1).tolist() == [0.625, 0.0]
    assert compute_metrics([0, 0], [0.1, 0.9])["auc"] is None


def _pairwise_auc(prob: np.ndarray, deformed: np.ndarray) -> np.ndarray:
    """The AUC counted over every deformed-intact pair (ties half): the definition the rank statistic must equal."""
    pos, neg = prob[..., deformed][..., :, None], prob[..., ~deformed][..., None, :]
    return (pos > neg).mean((-2, -1)) + 0.5 * (pos == neg).mean((-2, -1))


def test_rank_auc_equals_the_pairwise_count_with_ties():
    rng = np.random.default_rng(7)
    for _ in range(300):
        n = int(rng.integers(2, 80))
        prob = rng.integers(0, int(rng.integers(2, 12)), size=(3, n)) / 10  # many ties, within and across classes
        deformed = rng.random(n) < rng.uniform(0.1, 0.9)
        if not deformed.any() or deformed.all():
            assert np.isnan(roc_auc(prob, deformed)).all()
            continue
        assert np.array_equal(roc_auc(prob, deformed), _pairwise_auc(prob, deformed))


def test_auc_per_row_with_labels_per_row():
    rng = np.random.default_rng(3)
    prob, deformed = rng.random((4, 2, 30)).round(1), rng.random((4, 1, 30)) < 0.5
    got = roc_auc(prob, deformed)
    assert got.shape == (4, 2)
    for b in range(4):
        assert np.array_equal(got[b], _pairwise_auc(prob[b], deformed[b, 0]))


def _peak_mib(fn) -> float:
    import tracemalloc

    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def test_auc_memory_grows_with_the_photos_not_their_pairs():
    rng = np.random.default_rng(0)
    prob, deformed = rng.random((2, 10_000)), rng.random(10_000) < 0.6  # 24 million pairs per row
    assert _peak_mib(lambda: roc_auc(prob, deformed)) < 10


def test_metrics_of_many_photos_hold_bounded_memory():
    rng = np.random.default_rng(0)
    y = (rng.random(5_000) < 0.5).astype(int)
    prob = np.clip(y + rng.normal(0, 0.4, y.size), 0, 1)
    assert _peak_mib(lambda: compute_metrics(y, prob)) < 60  # a bootstrap of 2000 resamples at once: 240 MiB


def test_a_nan_probability_is_named():
    with pytest.raises(UserError, match=r"got nan \(image 1"):
        compute_metrics([0, 1, 1], [0.2, float("nan"), 0.7])
