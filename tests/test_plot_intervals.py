"""Intervals drawn on identification figures (issue 24): the stabilisation diagram marks the
identified model's modes with their frequency interval and damping, read back from the
figure's artists against ``frequency_std``/``damping_std``."""

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

import sdctrl as sd


def _model_row(fig):
    ax = fig.axes[1]
    bars = [c for c in ax.containers if c.get_label().startswith("identified")]
    assert len(bars) == 1
    bar = bars[0]
    centre = bar.lines[0].get_xdata()
    seg = bar.lines[2][0].get_segments()
    lo = np.array([min(s[0][0], s[1][0]) for s in seg])
    hi = np.array([max(s[0][0], s[1][0]) for s in seg])
    texts = [t.get_text() for t in ax.texts]
    return bar, np.asarray(centre), lo, hi, texts


def test_stabilisation_marks_the_modes_with_their_intervals(chain_identified):
    frf, cm, _ = chain_identified
    st = cm.stabilisation
    assert st is not None and len(st.poles) >= 3
    fig = sd.plot.stabilisation(st.poles, frf, orders=st.orders, model=cm)
    bar, centre, lo, hi, texts = _model_row(fig)
    assert bar.get_label() == "identified (95% interval)"
    up = cm.poles.imag > 0
    np.testing.assert_allclose(centre, cm.frequency[up])
    # the drawn interval is f +- 1.96 frequency_std (Hz)
    np.testing.assert_allclose(0.5 * (hi - lo), 1.959964 * cm.frequency_std[up], rtol=1e-5)
    np.testing.assert_allclose(0.5 * (hi + lo), cm.frequency[up], rtol=1e-12)
    # the row sits above the last order, inside the axes
    y = bar.lines[0].get_ydata()
    assert np.all(y > np.max(st.orders)) and fig.axes[1].get_ylim()[1] > y[0]
    # damping +- 1.96 damping_std in percent, one text per mode
    want = [f"{100 * z:.3g} +- {100 * 1.959964 * s:.2g} %"
            for z, s in zip(cm.damping[up], cm.damping_std[up])]
    assert texts == want
    # intervals of positive width around each mode, a few line spacings at most at 2% noise
    # (their calibration against the truth is tests/test_statistics*.py's)
    df = frf.freq[1] - frf.freq[0]
    assert np.all((lo < centre) & (centre < hi) & (hi - lo < 2 * df))
    # with the model the legend lists the row
    assert "identified (95% interval)" in [t.get_text() for t in fig.legends[0].get_texts()]


def test_stabilisation_interval_follows_the_level(chain_identified):
    frf, cm, _ = chain_identified
    st = cm.stabilisation
    _, _, lo95, hi95, _ = _model_row(sd.plot.stabilisation(st.poles, frf, model=cm))
    bar, _, lo50, hi50, texts = _model_row(sd.plot.stabilisation(st.poles, frf, model=cm,
                                                                 level=0.5))
    assert bar.get_label() == "identified (50% interval)"
    np.testing.assert_allclose((hi50 - lo50) / (hi95 - lo95), 0.674490 / 1.959964, rtol=1e-5)
    # a model without statistics: the mode is marked, its interval not determined
    bare = sd.ComplexModeModel(cm.poles, cm.residues)
    _, centre, lo, hi, texts = _model_row(sd.plot.stabilisation(st.poles, frf, model=bare))
    np.testing.assert_allclose(centre, cm.frequency[cm.poles.imag > 0])
    assert np.all(hi == lo) and all(t.endswith("+- n/a %") for t in texts)
    # only the modes within the band shown
    f = np.sort(cm.frequency)
    band = (0.5 * (f[0] + f[1]), frf.freq[-1])
    _, centre, _, _, texts = _model_row(sd.plot.stabilisation(st.poles, frf, model=cm,
                                                              band=band))
    assert centre.size == len(texts) == 2
    with pytest.raises(ValueError, match="level"):
        sd.plot.stabilisation(st.poles, frf, model=cm, level=95)
    with pytest.raises(TypeError, match="model must be an identified ComplexModeModel"):
        sd.plot.stabilisation(st.poles, frf, model=frf)
    # without a model: no row, as before
    assert not sd.plot.stabilisation(st.poles, frf).axes[1].containers
