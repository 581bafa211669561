"""Charts: the error box plots name every mark in their legend and keep their texts inside the figure."""

from __future__ import annotations

import pytest

pytest.importorskip("matplotlib")
from mpl_checks import texts_inside_figure  # noqa: E402

from monovisual3d.figures.charts import plot_curves, plot_error_boxes  # noqa: E402


def test_error_boxes_have_labels() -> None:
    fig = plot_error_boxes({"a": [1.0, 2.0], "b": [2.0, 3.0]}, title="errors", reference_mm=2.5, reference_label="paper")
    (ax,) = fig.axes
    assert ax.get_ylabel() == "Euclidean error (mm)"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "quartiles, whiskers 1.5 IQR",
        "median",
        "mean",
        "outlier",
        "paper",
    ]
    assert texts_inside_figure(fig) == []


def test_error_boxes_legend_names_every_mark() -> None:
    fig = plot_error_boxes(
        {"a": [1.0, 2.0, 3.0, 50.0], "b": [2.0, 3.0]}, reference_mm=10, reference_label="paper", xlabel="configuration"
    )
    (ax,) = fig.axes
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts == ["quartiles, whiskers 1.5 IQR", "median", "mean", "outlier", "paper"]
    assert ax.get_xlabel() == "configuration" and ax.get_ylabel() == "Euclidean error (mm)"


def test_curves_have_one_line_per_name_and_reject_a_wrong_length() -> None:
    fig = plot_curves([1, 2, 4], {"a": [1.0, 2.0, 3.0], "b": [3.0, 2.0, 1.0]}, xlabel="fruit", ylabel="error (mm)")
    (ax,) = fig.axes
    assert [ln.get_label() for ln in ax.get_lines()] == ["a", "b"]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["a", "b"]
    with pytest.raises(ValueError, match=r"curves\['a'\]: expected 3 values, got 2"):
        plot_curves([1, 2, 4], {"a": [1.0, 2.0]}, xlabel="fruit", ylabel="mm")
