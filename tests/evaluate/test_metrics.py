import numpy as np
import pytest

from deformsim.errors import UserError
from deformsim.evaluate.metrics import compute_metrics, confusion_matrix


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
