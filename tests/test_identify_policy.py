"""Call-scoped policies of ``identify``: BLAS threads, progress bar, warnings' location."""

import warnings

import numpy as np
import pytest
from test_identify import BAND, ten_mode
from threadpoolctl import threadpool_info, threadpool_limits

import sdctrl as sd
from sdctrl.identification import IdentificationWarning
from sdctrl.identification._selection import AutoSelection


def _blas_threads():
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_blas_limit_is_scoped_and_restored_on_error(monkeypatch):
    frf, lam, _ = ten_mode(df=0.1)
    seen = []

    def failing_run(self, *args, **kwargs):
        seen.append(_blas_threads())
        raise RuntimeError("boom")

    monkeypatch.setattr(AutoSelection, "run", failing_run)
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        with pytest.raises(RuntimeError, match="boom"):
            sd.identify(frf, band=BAND, progress=False)
        assert _blas_threads() == before                 # restored, even on error
    assert seen and all(n == 1 for n in seen[0])        # one thread inside the search
    # and after a normal call
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        sd.identify(frf, poles=lam, band=BAND, progress=False)
        assert _blas_threads() == before


def test_progress_follows_config(monkeypatch, capsys):
    frf, lam, _ = ten_mode(df=0.1)
    monkeypatch.setattr(sd.config, "progress", False)
    sd.identify(frf, poles=lam, band=BAND)
    assert "identify" not in capsys.readouterr().err
    monkeypatch.setattr(sd.config, "progress", True)
    sd.identify(frf, poles=lam, band=BAND)
    assert "identify" in capsys.readouterr().err
    sd.identify(frf, poles=lam, band=BAND, progress=False)      # the argument wins
    assert "identify" not in capsys.readouterr().err


def test_warnings_point_at_the_caller():
    frf, lam, _ = ten_mode(df=0.1)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        cm = sd.identify(frf, poles=np.append(lam, lam[3]), band=BAND, optimizer="none",
                         progress=False)
    ours = [w for w in rec if issubclass(w.category, IdentificationWarning)]
    assert ours and len(ours) == len(cm.warnings)
    assert all(w.filename == __file__ for w in ours)
