import pytest

from deformsim.errors import UserError
from deformsim.evaluate.calibration import reliability


def test_bins_and_ece_match_hand_computed_values():
    y = [0, 0, 1, 1, 1, 0]
    prob = [0.05, 0.15, 0.15, 0.95, 1.0, 0.55]  # 1.0 belongs to the last bin
    r = reliability(y, prob, n_bins=10)
    full = {i: b for i, b in enumerate(r["bins"]) if b["n"]}
    assert len(r["bins"]) == 10 and r["n"] == 6
    assert [(b["lo"], b["hi"]) for b in r["bins"][:2]] == [(0.0, 0.1), (0.1, 0.2)] and r["bins"][-1]["hi"] == 1.0
    assert list(full) == [0, 1, 5, 9]
    assert [full[i]["n"] for i in full] == [1, 2, 1, 2]
    assert [full[i]["prob"] for i in full] == pytest.approx([0.05, 0.15, 0.55, 0.975])
    assert [full[i]["freq"] for i in full] == pytest.approx([0.0, 0.5, 0.0, 1.0])
    assert r["bins"][3] == {"lo": 0.3, "hi": 0.4, "n": 0, "prob": None, "freq": None}
    # ECE = (1 * 0.05 + 2 * 0.35 + 1 * 0.55 + 2 * 0.025) / 6
    assert r["ece"] == pytest.approx(1.35 / 6)


def test_bin_edges_belong_to_the_upper_bin():
    r = reliability([0, 1, 1, 0], [0.0, 0.5, 1.0, 0.25], n_bins=2)
    assert [b["n"] for b in r["bins"]] == [2, 2]
    assert [b["prob"] for b in r["bins"]] == pytest.approx([0.125, 0.75])
    assert [b["freq"] for b in r["bins"]] == [0.0, 1.0]
    assert r["ece"] == pytest.approx((2 * 0.125 + 2 * 0.25) / 4)


def test_calibrated_predictions_have_zero_ece():
    r = reliability([0, 0, 0, 1, 1, 1, 1, 0], [0.25] * 4 + [0.75] * 4, n_bins=4)
    assert r["ece"] == pytest.approx(0.0)


@pytest.mark.parametrize("y, prob, n_bins", [([0, 1], [0.2, 1.2], 10), ([0, 2], [0.2, 0.3], 10),
                                             ([0, 1], [0.2], 10), ([0, 1], [0.2, 0.3], 0)])
def test_bad_input_is_a_user_error(y, prob, n_bins):
    with pytest.raises(UserError):
        reliability(y, prob, n_bins)
