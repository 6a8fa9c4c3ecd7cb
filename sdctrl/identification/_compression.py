"""Data compression for the pole search (thesis 3.2.1, scale).

The stacked data ``Y = [Re H; Im H]`` (2 nf x ns na) only enter the pole search through
their dominant column space; ``Y`` is compressed once to ``Y V`` with ``V`` a real
orthonormal basis (exact SVD for small sets, randomised range finder otherwise), so that
the pole search costs the same for 10 or 10,000 sensors and residues stay real.  The
final residues are solved on the full data (cost linear in the number of sensors).

Internal module: the functions trust their inputs (validated by ``identify``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl.identification._residues import stack

__all__ = ["channel_weights", "compress", "compressed_data", "measurable_noise"]

#: weights of quiet channels at most this many times the median channel's
MAX_WEIGHT = 1e3
#: median ratio of the fourth- to the second-difference noise levels above which the
#: second differences measure noise (:func:`channel_weights`)
NOISE_AGREEMENT = 0.5


def channel_weights(Hm: np.ndarray) -> np.ndarray:
    """Weight ``1 / sigma_c`` of each channel in the pole search, ``sigma_c`` its noise level.

    The cost (3.11) sums the channels as they come: a mode seen on a few quiet channels
    only (a blade mode on its own blade) moves it less than the noise of the loud ones,
    the pole search and the significance test go where the loud channels' noise is, and
    compression (:func:`compress`) mixes that noise into every column.  Each channel is
    divided by its noise level, a constant per channel (the poles are those of the
    data; the residues, solved per channel at fixed poles (3.16), do not change): the
    cost is then the likelihood of noise of one level per channel.  ``sigma_c^2`` is the
    median over the lines of ``|H_(i-1) - 2 H_i + H_(i+1)|^2`` (second differences pass
    noise independent between lines and suppress the smooth response; the median keeps
    the floor between the resonances), normalised to a geometric mean of one and held
    within :data:`MAX_WEIGHT` of the median channel.  The second differences measure the
    noise only where they agree with the fourth, ``median |d^4 H|^2 / 70`` against
    ``median |d^2 H|^2 / 6`` (equal for noise independent between lines, far below for a
    smooth response): when they do not on most channels (median ratio below
    :data:`NOISE_AGREEMENT`: noise-free data, 0.001 on the testbed family; at 1% noise
    0.59-0.94) the data show no noise to weigh by and every weight is one.

    Parameters
    ----------
    Hm : ndarray, shape (nf, m)
        Complex FRF data, one column per sensor/actuator pair.

    Returns
    -------
    ndarray, shape (m,)
        Positive weights (all ones with fewer than seven lines or no measurable noise).
    """
    levels = _difference_levels(Hm)
    if not _agree(levels):
        return np.ones(Hm.shape[1])
    s2 = levels.s2 * 4.0**levels.k                  # exact: back to the unit of Hm
    ref = float(np.median(s2))
    s2 = np.clip(s2, ref / MAX_WEIGHT**2, None)
    w = 1.0 / np.sqrt(s2)
    return w / np.exp(np.mean(np.log(w)))


def measurable_noise(Hm: np.ndarray) -> bool:
    """Whether the data show noise independent between lines: on most channels (median
    ratio at least :data:`NOISE_AGREEMENT`) their second differences agree with their fourth,
    ``median |d^4 H|^2 / 70`` against ``median |d^2 H|^2 / 6`` (:func:`channel_weights`);
    False with fewer than seven lines.  Independent of the scale of ``Hm``.

    Parameters
    ----------
    Hm : ndarray, shape (nf, m)
        Complex FRF data, one column per sensor/actuator pair.

    Returns
    -------
    bool
    """
    return _agree(_difference_levels(Hm))


@dataclass(frozen=True, eq=False)
class _Levels:
    """Per channel, ``median |d^2 H|^2`` (``s2``) and ``median |d^4 H|^2`` (``s4``) of the
    data scaled by ``2^-k`` (exact), ``k`` the binary exponent of their largest entry."""

    s2: np.ndarray
    s4: np.ndarray
    k: int


def _difference_levels(Hm: np.ndarray) -> _Levels | None:
    """The second- and fourth-difference levels of ``Hm`` (:class:`_Levels`), scaled so
    that their squares neither under- nor overflow whatever the unit of ``Hm``; None with
    fewer than seven lines or no nonzero entry."""
    big = float(np.max(np.abs(Hm))) if Hm.size else 0.0
    if Hm.shape[0] < 7 or not big > 0:
        return None
    k = int(np.frexp(big)[1])
    d = Hm * 2.0**-k
    d = d[:-2] - 2.0 * d[1:-1] + d[2:]
    s2 = np.median(d.real**2 + d.imag**2, axis=0)
    d = d[:-2] - 2.0 * d[1:-1] + d[2:]
    return _Levels(s2, np.median(d.real**2 + d.imag**2, axis=0), k)


def _agree(levels: _Levels | None) -> bool:
    """Whether the second differences agree with the fourth on most channels (module notes
    of :func:`channel_weights`): noise independent between lines."""
    if levels is None or not float(np.median(levels.s2)) > 0:
        return False
    ratio = 6.0 * levels.s4 / np.maximum(70.0 * levels.s2, 1e-300)
    return bool(np.median(ratio) >= NOISE_AGREEMENT)


def compress(Hm: np.ndarray, rank: int, seed=0, power: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Real orthonormal basis ``V`` (m, r) of the dominant row space of ``Y = [Re H; Im H]``.

    Exact (SVD) when ``m`` is small, otherwise a randomised range finder with ``power``
    subspace iterations (Halko, Martinsson & Tropp 2011); columns are ordered by
    decreasing singular value, which are returned too.

    Parameters
    ----------
    Hm : ndarray, shape (nf, m)
        Complex FRF data, one column per sensor/actuator pair.
    rank : int
        Rank ``r`` of the basis (capped at ``m`` and ``2 nf``).
    seed : int, optional
        Seed of the random test matrix of the range finder.
    power : int
        Number of subspace (power) iterations of the range finder.

    Returns
    -------
    V : ndarray, shape (m, r)
        Real orthonormal basis.
    sv : ndarray, shape (r,)
        Singular values of ``Y`` along the columns of ``V``, decreasing.
    """
    nf, m = Hm.shape
    rank = int(min(rank, m, 2 * nf))
    if m <= max(3 * rank, 300):
        Y = stack(Hm)
        if 2 * nf >= m:
            ev, W = np.linalg.eigh(Y.T @ Y)
            order = np.argsort(ev)[::-1][:rank]
            return W[:, order], np.sqrt(np.clip(ev[order], 0, None))
        _, sv, Vt = np.linalg.svd(Y, full_matrices=False)
        return Vt[:rank].T.copy(), sv[:rank]
    rng = np.random.default_rng(seed)
    ell = min(m, rank + 10)
    Om = rng.standard_normal((nf, ell)) + 1j * rng.standard_normal((nf, ell))
    Z = (Hm.conj().T @ Om).real                       # Y^T Omega, without stacking Y
    V, _ = np.linalg.qr(Z)
    for _ in range(power):
        W = Hm @ V                                    # Y V as complex (nf, ell)
        Z = Hm.real.T @ W.real + Hm.imag.T @ W.imag   # Y^T (Y V)
        V, _ = np.linalg.qr(Z)
    W = stack(Hm @ V)
    _, sv, Vt = np.linalg.svd(W, full_matrices=False)
    return (V @ Vt.T)[:, :rank], sv[:rank]


def compressed_data(Hm: np.ndarray, rank: int, seed=0):
    """Stacked data of the pole search, compressed to ``rank`` columns when it helps.

    Parameters
    ----------
    Hm : ndarray, shape (nf, m)
        Complex FRF data.
    rank : int
        Requested rank; ``rank <= 0`` or ``rank >= m`` keeps the full data.
    seed : int, optional
        Seed of :func:`compress`.

    Returns
    -------
    Y : ndarray, shape (2 nf, r)
        ``[Re; Im]`` of ``Hm V`` (or of ``Hm``).
    V : ndarray, shape (m, r), or None
        The compression basis (None when uncompressed).
    rank : int
        The rank used (``m`` when uncompressed).
    """
    m = Hm.shape[1]
    if rank <= 0 or rank >= m:
        return stack(Hm), None, m
    V, _sv = compress(Hm, rank, seed)
    return stack(Hm @ V), V, rank
