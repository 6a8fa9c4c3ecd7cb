"""Cost functions and correlation criteria against closed forms."""

import numpy as np
import pytest

import sdctrl as sd
from sdctrl.updating import comac, logls, mac, quadratic, relative_error


def test_costs_closed_form():
    f = np.linspace(1, 10, 50)
    H = np.exp(1j * f)[:, None, None] * np.ones((50, 2, 3))
    t = sd.FRF(f, H)
    assert quadratic(t, t) == 0 and logls(t, t) == 0 and relative_error(t, t) == 0
    m = sd.FRF(f, 2 * H)
    assert logls(m, t) == pytest.approx(np.log(2) ** 2, rel=1e-12)
    assert relative_error(m, t) == pytest.approx(1.0)
    assert quadratic(m, t) == pytest.approx(1.0)
    rot = sd.FRF(f, H * np.exp(0.3j))
    assert logls(rot, t) == pytest.approx(0, abs=1e-20)
    assert logls(rot, t, phase=True) == pytest.approx(0.09, rel=1e-10)
    # quantity mismatch is converted before comparing
    assert logls(t.to("acceleration"), t) == pytest.approx(0, abs=1e-20)
    with pytest.raises(ValueError, match="same shape"):
        quadratic(np.ones(3), np.ones(4))


def test_mac_and_comac():
    rng = np.random.default_rng(0)
    phi = rng.standard_normal((12, 4))
    M = mac(phi, -3 * phi)
    assert np.allclose(np.diag(M), 1) and np.all((M >= 0) & (M <= 1 + 1e-12))
    q, _ = np.linalg.qr(phi)
    assert np.allclose(mac(q, q), np.eye(4), atol=1e-12)
    assert np.allclose(comac(phi, 2 * phi), 1)
    bad = phi.copy()
    bad[3] = rng.standard_normal(4)
    c = comac(phi, bad)
    assert np.argmin(c) == 3 and np.delete(c, 3).min() == pytest.approx(1)
    with pytest.raises(ValueError, match="same number of rows"):
        mac(phi, phi[:5])
