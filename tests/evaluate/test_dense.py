"""Metrics of the dense-label heads against values worked out by hand."""

import numpy as np
import pytest

from deformsim.evaluate.dense import average_precision, family_metrics, region_metrics, severity_metrics, spearman


def test_spearman_uses_ranks_with_ties():
    assert spearman([1, 2, 3, 4], [10, 20, 30, 1000]) == pytest.approx(1.0)
    assert spearman([1, 2, 3, 4], [4, 3, 2, 1]) == pytest.approx(-1.0)
    # ranks [1, 2.5, 2.5, 4] against [1, 2, 3, 4]: Pearson of the ranks
    assert spearman([0, 5, 5, 9], [1, 2, 3, 4]) == pytest.approx(np.corrcoef([1, 2.5, 2.5, 4], [1, 2, 3, 4])[0, 1])
    assert spearman([1, 1, 1], [1, 2, 3]) is None


def test_severity_metrics_and_mean_baseline():
    m = severity_metrics([0, 0, 4, 8], [1, 0, 5, 5], train_mean=2.0)
    assert m["mae_mm"] == pytest.approx(5 / 4) and m["rmse_mm"] == pytest.approx(np.sqrt(11 / 4))
    assert m["baseline_mae_mm"] == pytest.approx((2 + 2 + 2 + 6) / 4) and m["n"] == 4


def test_average_precision():
    assert average_precision([1, 0, 1, 0], [0.9, 0.8, 0.7, 0.1]) == pytest.approx((1 + 2 / 3) / 2)
    assert average_precision([0, 0], [0.3, 0.2]) is None


def test_family_metrics_skip_absent_families_in_macro():
    y = np.array([[1, 0, 0], [0, 0, 1], [1, 0, 1], [0, 0, 0]])
    p = np.array([[0.9, 0.2, 0.1], [0.6, 0.1, 0.8], [0.7, 0.3, 0.4], [0.1, 0.6, 0.2]])
    m = family_metrics(y, p, ["dent", "twist", "crease"], 0.5)
    dent = m["families"]["dent"]
    assert (dent["precision"], dent["recall"], dent["ap"]) == (pytest.approx(2 / 3), 1.0, 1.0)
    assert m["families"]["twist"] == {"ap": None, "f1": 0.0, "precision": 0.0, "recall": 0.0, "n_positive": 0}
    crease = m["families"]["crease"]
    assert crease["recall"] == 0.5 and crease["ap"] == 1.0
    assert m["macro_ap"] == 1.0 and m["macro_f1"] == pytest.approx((0.8 + 2 / 3) / 2)


def test_region_metrics_pool_pixels():
    truth = np.zeros((2, 4, 4), bool)
    truth[0, :2, :2] = True  # 4 pixels
    prob = np.zeros((2, 4, 4))
    prob[0, :2, :1] = 0.9  # 2 right
    prob[1, 3, 3] = 0.7  # 1 false alarm on an image without region
    m = region_metrics(truth, prob, 0.5)
    assert m["iou"] == pytest.approx(2 / 5) and m["pixel_f1"] == pytest.approx(4 / 7)
    assert m["mean_iou"] == pytest.approx((0.5 + 0) / 2)
    assert region_metrics(np.zeros((1, 2, 2), bool), np.zeros((1, 2, 2)), 0.5)["iou"] == 1.0
