"""The training-curve figures: one series per model, labelled axes, the legend beside the data."""

from deformsim.learn.train_file import Epoch
from deformsim.report import figures


def test_curves_have_one_series_per_model_a_y_label_and_the_legend_outside(monkeypatch):
    seen = []
    monkeypatch.setattr(figures, "_png", lambda fig: seen.append(fig) or b"png")
    hist = [Epoch(epoch=e, loss=1 / e, acc=0.5, val_loss=1.0, val_acc=0.6, seconds=1.0) for e in (1, 2, 3)]
    no_val = [h.model_copy(update={"val_acc": None, "val_loss": None}) for h in hist]
    assert figures.curves_png({"black": hist, "procedural": no_val, "green": None}) == [b"png", b"png"]
    (loss,), (acc,) = (f.axes for f in seen)
    assert [ax.get_ylabel() for ax in (loss, acc)] == ["training loss (cross-entropy)", "validation accuracy"]
    assert [line.get_label() for line in loss.lines] == ["black", "procedural"]
    assert [line.get_linestyle() for line in acc.lines[:2]] == ["-", "--"]  # dashed: no validation images
    for ax in (loss, acc):
        anchor = ax.get_legend().get_bbox_to_anchor().transformed(ax.transAxes.inverted())
        assert anchor.x0 > 1  # beside the axes, never over the data
    assert figures.curves_png({"black": []}) == []
