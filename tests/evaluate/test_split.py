import pandas as pd
import pytest

from deformsim.errors import UserError
from deformsim.evaluate.experiments import grouped_split


def table(n_intact: int, n_deformed: int, views: int = 4) -> pd.DataFrame:
    rows = []
    for s in range(n_intact + n_deformed):
        y = int(s >= n_intact)
        rows += [{"id": f"{s:06d}_c{c}", "sample": s, "y": y, "path": f"{s}_{c}.png"} for c in range(views)]
    return pd.DataFrame(rows)


@pytest.mark.parametrize("n_intact, n_deformed", [(10, 10), (7, 13), (2, 2), (25, 5)])
def test_split_keeps_views_together_and_balance(n_intact, n_deformed):
    t = table(n_intact, n_deformed)
    train, test = grouped_split(t, 0.8, seed=1)
    assert set(train["sample"]).isdisjoint(test["sample"])
    assert len(train) + len(test) == len(t)
    assert sorted(train["id"].tolist() + test["id"].tolist()) == sorted(t["id"])
    assert (test.groupby("sample").size() == 4).all()
    for y, n in ((0, n_intact), (1, n_deformed)):
        n_test = test[test["y"] == y]["sample"].nunique()
        assert n_test == min(max(1, round(0.2 * n)), n - 1)  # each class keeps its share in both parts
        assert train[train["y"] == y]["sample"].nunique() == n - n_test


def test_split_is_seeded():
    t = table(10, 10)
    a = grouped_split(t, 0.8, seed=5)[1]["sample"].tolist()
    assert a == grouped_split(t, 0.8, seed=5)[1]["sample"].tolist()
    assert any(grouped_split(t, 0.8, seed=s)[1]["sample"].tolist() != a for s in range(6, 12))


def test_split_needs_two_samples_per_class():
    with pytest.raises(UserError, match="y=1"):
        grouped_split(table(3, 1), 0.8, seed=0)


def test_split_rejects_a_sample_with_mixed_labels():
    t = table(3, 3)
    t.loc[0, "y"] = 1
    with pytest.raises(UserError, match="sample 0"):
        grouped_split(t, 0.8, seed=0)


def test_twins_stay_together_and_unpaired_splits_are_as_before():
    """generate.paired: a dented object and its intact twin share one scene, so a twin on each side would test on a
    scene seen in training with the other label; the split keeps them together, and splits lone samples as before."""
    from deformsim.dataset.tables import split

    t = table(20, 20)
    assert sorted(set(t.iloc[split(t, 0.8, 3)[1]]["sample"])) == [4, 5, 7, 19, 21, 30, 35, 36]  # as before twins
    t["pair"] = t["sample"] % 20  # samples s and s + 20: twins
    t = t[(t["sample"] != 25) | t["id"].str.endswith("c0")]  # twin 25 lost 3 of its views (train.min_region)
    t = t[t["sample"] != 7].reset_index(drop=True)  # twin 7 lost all of them: its pair holds one class
    train, test = grouped_split(t, 0.8, seed=3)
    assert set(train["pair"]).isdisjoint(test["pair"]) and len(train) + len(test) == len(t)
    assert test["pair"].nunique() == 4 and 7 in set(train["pair"])  # 19 twins: 4 held out; a lone pair trains
    assert (test.groupby("pair")["y"].nunique() == 2).all()
