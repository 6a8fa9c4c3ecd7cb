"""Bounds of the FRF of an uncertain model over drawn parameter values (5.5).

The magnitude and phase envelopes of :meth:`UncertainModel.frf_envelope
<sdctrl.robust.UncertainModel.frf_envelope>`: the FRF of the model at every drawn
normalised parameter vector ``delta`` (box vertices and interior samples), reduced to its
elementwise minimum and maximum.  The draws are cut in chunks that any executor may run
(min and max are exact, so the envelope is the serial run's bit for bit); on a Dask client
the model is scattered to the workers once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sdctrl._lib.parallel import chunked, map_chunks
from sdctrl._lib.statespace import ss_frf

__all__ = ["CHUNK", "box_draws", "envelope_of_draws"]

#: parameter draws per task of an executor
CHUNK = 50


def box_draws(nb: int, n_samples: int, max_vertices: int, rng) -> np.ndarray:
    """Normalised parameter draws ``(n_draws, nb)``: every vertex of the box when there are
    at most ``max_vertices`` (else that many random ones), then ``n_samples`` uniform
    interior samples (drawn from ``rng`` in that order)."""
    if nb == 0:
        verts = np.zeros((1, 0))
    elif 2 ** nb <= max_vertices:
        verts = np.array(np.meshgrid(*[[-1.0, 1.0]] * nb, indexing="ij")).reshape(nb, -1).T
    else:
        verts = rng.choice([-1.0, 1.0], size=(max_vertices, nb))
    return np.vstack([verts, rng.uniform(-1, 1, size=(n_samples, nb))])


@dataclass(frozen=True, eq=False)
class _Nominal:
    """What every chunk reads: the uncertain model, the lines (rad/s), the nominal FRF."""

    um: object
    w: np.ndarray
    H0: np.ndarray


def _chunk_bounds(deltas, nom) -> tuple:
    """``(|H| min, |H| max, phase-lag min, max)`` (rad, about the nominal) over ``deltas``."""
    mag_min = np.abs(nom.H0)
    mag_max = mag_min.copy()
    ph_min = np.zeros_like(mag_min)
    ph_max = np.zeros_like(mag_min)
    um = nom.um
    for d in deltas:                # the perturbed matrices, without a StateSpace per draw
        H = ss_frf(*um._matrices(*um._perturbed_matrices(d)), nom.w)
        a = np.abs(H)
        mag_min, mag_max = np.minimum(mag_min, a), np.maximum(mag_max, a)
        dp = np.angle(H * np.conj(nom.H0))
        ph_min, ph_max = np.minimum(ph_min, dp), np.maximum(ph_max, dp)
    return mag_min, mag_max, ph_min, ph_max


def envelope_of_draws(um, freq, deltas, executor=None) -> dict:
    """Min/max magnitude and phase of the FRF of ``um`` over the draws ``deltas``.

    Parameters
    ----------
    um : UncertainModel
        The uncertain model.
    freq : ndarray, shape (nf,)
        Frequencies (Hz), checked.
    deltas : ndarray, shape (nd, nblocks)
        Normalised parameter vectors (each entry in [-1, 1]).
    executor : concurrent.futures.Executor, optional
        Runs the chunks of ``CHUNK`` draws (None: serially).

    Returns
    -------
    dict
        ``freq``, ``nominal`` (complex), ``mag_min``, ``mag_max``, ``phase_min``,
        ``phase_max`` (degrees, unwrapped around the nominal phase), each ``(nf, ns, na)``.
    """
    w = 2 * np.pi * np.asarray(freq, float)
    nom = um.nominal
    H0 = ss_frf(nom.A, nom.B, nom.C, nom.D, w)
    parts = map_chunks(_chunk_bounds, chunked(deltas, CHUNK), _Nominal(um, w, H0), executor,
                       progress=False)
    mag_min = np.abs(H0)
    mag_max = mag_min.copy()
    ph_min = np.zeros_like(mag_min)
    ph_max = np.zeros_like(mag_min)
    for lo, hi, plo, phi in parts:
        mag_min, mag_max = np.minimum(mag_min, lo), np.maximum(mag_max, hi)
        ph_min, ph_max = np.minimum(ph_min, plo), np.maximum(ph_max, phi)
    p0 = np.unwrap(np.angle(H0), axis=0)
    return {"freq": np.asarray(freq, float), "nominal": H0, "mag_min": mag_min,
            "mag_max": mag_max, "phase_min": np.degrees(p0 + ph_min),
            "phase_max": np.degrees(p0 + ph_max)}
