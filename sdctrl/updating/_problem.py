"""The update problem: a parametric reduced model (4.17) facing a placed test.

:class:`UpdateProblem` evaluates, for parameter values ``p``, the two criteria of the
update (thesis 4.1): the frequencies of FE modes paired by MAC with the test's modes
(4.8)-(4.9), and the logLS residual ``log|H_FE(p)| - log|H_test|`` whose mean square is the
cost (3.12).  Damping follows the choice of :func:`sdctrl.update`:

- ``"matrix"``: the FE model's ``C`` (plus the parameters' ``dC``), projected (4.17);
- ``"modal"``: modal damping set on the reduced model's normal modes at a reference point
  ``p_ref``: test modes paired by MAC carry their identified damping (the full identified
  ``Gamma`` block between paired modes when normal modes were identified, signs following
  the shapes), the other modes the mean identified damping ratio; a given ratio holds on
  every mode (identified damping does not override it).
  The reduced damping matrix ``M X Gamma X^T M`` is then fixed in the reduced coordinates,
  so the cost stays smooth in ``p``; :meth:`UpdateProblem.damped_at` moves the reference.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from sdctrl.updating._ritz_basis import reduced_basis
from sdctrl.updating._costs import mac as mac_matrix
from sdctrl.updating._parametric import damping_from_modal, reduced_model

__all__ = ["UpdateProblem", "apply_parameters", "build_problem", "cluster_pairing", "log_frf"]

#: pairs with a MAC below this are not used to transfer the identified damping
MAC_DAMPING = 0.6
#: FE modes whose frequencies agree to this relative tolerance are paired as a subspace
CLUSTER_RTOL = 1e-4


def log_frf(rm, p, omega) -> np.ndarray:
    """``log |H(p)|`` of a reduced model (the logLS (3.12) term), floored at ``1e-300``.

    Parameters
    ----------
    rm : ReducedModel
        The reduced parametric model.
    p : array_like, shape (npar,)
        Parameter values.
    omega : ndarray, shape (nf,)
        Lines (rad/s).

    Returns
    -------
    ndarray, shape (nf, ns, na)
    """
    return np.log(np.abs(rm.frf(p, omega)) + 1e-300)


def cluster_pairing(cphi_fe, freq, shapes, rtol: float = CLUSTER_RTOL):
    """MAC pairing (4.9) of test modes with FE modes, robust to (nearly) multiple FE modes.

    Within a cluster of FE modes whose frequencies agree to ``rtol`` (the doublets of a
    symmetric structure) the individual shapes are arbitrary combinations that rotate with
    the smallest change; each member is given the MAC of the test shape with the cluster's
    *subspace* (``||Q^H y||^2 / ||y||^2``), which is stable.  The assignment then maximises
    the total MAC, one FE mode per test mode.

    Parameters
    ----------
    cphi_fe : ndarray, shape (ns, m)
        FE observabilities, modes sorted by frequency (``m >= n``).
    freq : ndarray, shape (m,)
        Their frequencies.
    shapes : ndarray, shape (ns, n)
        Test observabilities.
    rtol : float
        Relative frequency tolerance of a cluster.

    Returns
    -------
    index : ndarray of int, shape (n,)
        FE mode paired with each test mode.
    mac : ndarray, shape (n,)
        (Subspace) MAC of each pair.
    """
    from scipy.optimize import linear_sum_assignment

    macs = mac_matrix(cphi_fe, shapes)
    scale = max(float(np.abs(freq).max()), 1e-300)
    starts = np.flatnonzero(np.r_[True, np.diff(freq) > rtol * np.maximum(freq[1:], scale * 1e-9)])
    bounds = np.r_[starts, freq.size]
    Y = np.asarray(shapes)
    ny = np.sum(np.abs(Y) ** 2, axis=0)
    for a, b in itertools.pairwise(bounds):
        if b - a > 1:
            Q, _ = np.linalg.qr(cphi_fe[:, a:b])
            sub = np.sum(np.abs(Q.conj().T @ Y) ** 2, axis=0) / np.maximum(ny, 1e-300)
            macs[a:b] = sub[None, :]
    rows, cols = linear_sum_assignment(-macs)
    index = np.empty(macs.shape[1], int)
    index[cols] = rows
    return index, macs[index, np.arange(macs.shape[1])]


def apply_parameters(fe, parameters, values):
    """FE model with the parameters applied: ``M + sum p dM``, ``C + sum p dC``, ``K + sum p dK``.

    Parameters
    ----------
    fe : FEModel
        The nominal model.
    parameters : sequence of Parameter
        The parameters.
    values : sequence of float or dict
        Their values (in order, or by name).

    Returns
    -------
    FEModel
        Sparse when ``fe`` is, with the same labels, nodes, elements and
        ``fe.assembly``: the element record of the nominal model, so that
        :meth:`~sdctrl.FEModel.stiffness_parameter` and the other helpers still work on
        the updated model (they build their matrices from the nominal element properties:
        ``p`` then scales the nominal stiffness or mass of the selected elements).
    """
    from sdctrl.fe import FEModel

    if isinstance(values, dict):
        values = [values[p.name] for p in parameters]
    mats = {"M": fe.M, "C": fe.C, "K": fe.K}
    for par, v in zip(parameters, values):
        for key, X in zip(("M", "C", "K"), par.matrices()):
            if X is None or v == 0:
                continue
            base = mats[key]
            if base is None:
                base = sp.csr_matrix(X.shape) if fe.sparse else np.zeros(X.shape)
            if fe.sparse:
                mats[key] = sp.csr_matrix(base) + float(v) * sp.csr_matrix(X)
            else:
                mats[key] = np.asarray(base) + float(v) * (X.toarray() if sp.issparse(X) else X)
    return FEModel(mats["M"], mats["K"], mats["C"], dofs=fe.dofs,
                   nodes=None if fe.nodes is None else dict(fe.nodes), elements=fe.elements,
                   assembly=fe.assembly)


@dataclass(frozen=True, eq=False)
class UpdateProblem:
    """A parametric reduced model facing a test (internal to update and identifiability).

    Parameters
    ----------
    rm : ReducedModel
        The parametric reduced model on the test's sensors and actuators.
    basis : ReducedBasis
        Its Ritz basis (shapes on the FE DOFs).
    measured : Measured
        The test.
    modes : MeasuredModes or None
        The test's modes (pairing, damping from data).
    damping : str
        ``"matrix"`` or ``"modal"``.
    ratio : float or None
        Uniform damping ratio (``"modal"`` without identified modes).
    p_ref : ndarray or None
        Reference point of the modal damping.
    fmax : float
        Highest normal-mode frequency (Hz) of the basis.
    """

    rm: object
    basis: object
    measured: object
    modes: object
    damping: str
    ratio: float | None
    p_ref: np.ndarray | None
    fmax: float

    @property
    def npar(self) -> int:
        """Number of parameters."""
        return self.rm.npar

    # --- logLS (3.12) -------------------------------------------------------------------
    def log_response(self, p) -> np.ndarray:
        """``log |H_FE(p)|`` on the test's lines, sensors and actuators.

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        ndarray, shape (nf, ns, na)
        """
        return log_frf(self.rm, p, self.measured.omega)

    def residual(self, p) -> np.ndarray:
        """logLS residual vector, scaled so that its sum of squares is the cost (3.12).

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        ndarray, shape (nf * ns * na,)
        """
        r = (self.log_response(p) - self.measured.logH).ravel()
        return r / np.sqrt(r.size)

    def cost(self, p) -> float:
        """logLS cost (3.12): mean squared log-magnitude difference.

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        float
        """
        r = self.residual(p)
        return float(r @ r)

    # --- modes, pairing (4.8)-(4.9) -------------------------------------------------------
    def pairing(self, p):
        """FE modes of the reduced model at ``p`` paired by MAC with the test's modes.

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        index : ndarray of int
            Reduced-model mode paired with each test mode.
        mac : ndarray
            MAC of each pair.
        freq : ndarray
            Frequencies (Hz) of all reduced-model modes.
        X : ndarray
            The reduced modes.
        """
        w2, X = self.rm.modes(p)
        f = np.sqrt(np.clip(w2, 0, None)) / (2 * np.pi)
        ftop = 2.0 * float(self.modes.frequency.max()) if self.modes.n else 0.0
        m = max(int(np.searchsorted(f, ftop)), self.modes.n)
        index, mac = cluster_pairing(self.rm.c @ X[:, :m], f[:m], self.modes.shapes)
        return index, mac, f, X

    def frequency_residual(self, p) -> np.ndarray:
        """MAC-weighted relative frequency errors of the paired modes (4.8).

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        ndarray, shape (n_test_modes,)
        """
        index, mac, f, _ = self.pairing(p)
        fid = self.modes.frequency
        return mac * (f[index] - fid) / fid

    # --- damping ------------------------------------------------------------------------
    def damped_at(self, p) -> UpdateProblem:
        """Problem with the modal damping referenced at ``p`` (no change for ``"matrix"``).

        Parameters
        ----------
        p : array_like, shape (npar,)
            Parameter values.

        Returns
        -------
        UpdateProblem
        """
        if self.damping == "matrix":
            return self
        p = np.asarray(p, float)
        M = self.rm.matrices(p)[0]
        w2, X = self.rm.modes(p)
        w = np.sqrt(np.clip(w2, 0, None))
        if self.ratio is not None or self.modes is None or not self.modes.n:
            G = np.diag(2 * self.ratio * w)         # a given ratio holds on every mode
        else:
            G = self._modal_gamma(p, w)
        return replace(self, rm=self.rm.with_damping(damping_from_modal(M, X, G)), p_ref=p.copy())

    def _modal_gamma(self, p, w) -> np.ndarray:
        tm = self.modes
        index, mac, _f, X = self.pairing(p)
        zmean = float(np.mean(tm.damping))
        G = np.diag(2 * zmean * w)
        ok = mac >= MAC_DAMPING
        k = index[ok]
        if tm.Gamma is not None:
            cX = self.rm.c @ X[:, k]
            sign = np.sign(np.real(np.einsum("ij,ij->j", cX, np.conj(tm.shapes[:, ok]))))
            sign[sign == 0] = 1.0
            G[np.ix_(k, k)] = np.outer(sign, sign) * tm.Gamma[np.ix_(ok, ok)]
        else:
            G[k, k] = 2 * tm.damping[ok] * w[k]
        return G


def build_problem(fe, measured, parameters, damping, modes, *, fmax: float,
                  loads: str = "modal", p_ref=None) -> UpdateProblem:
    """Reduced basis, reduced model and damping of an update problem.

    Parameters
    ----------
    fe : FEModel
        The model (its normal modes up to ``fmax`` and the static correction modes of the
        test's actuators and of the parameters make the basis).
    measured : Measured
        The test placed on ``fe``.
    parameters : sequence of Parameter
        The parameters.
    damping : ("matrix", None) or ("modal", ratio or None)
        Damping choice.
    modes : MeasuredModes or None
        The test's modes.
    fmax : float
        Highest normal-mode frequency of the basis (Hz).
    loads : {"modal", "range"}
        Load shapes of the parameters' static correction modes.
    p_ref : array_like, optional
        Reference point of modal damping (default 0).

    Returns
    -------
    UpdateProblem
    """
    kind, ratio = damping
    basis = reduced_basis(fe, parameters, inputs=fe.point(list(measured.frf.actuators)),
                          fmax=fmax, loads=loads)
    rm = reduced_model(basis, parameters, measured.sensors, measured.actuators,
                       C=fe.C if kind == "matrix" else None)
    prob = UpdateProblem(rm, basis, measured, modes, kind, ratio, None, float(fmax))
    p0 = np.zeros(len(parameters)) if p_ref is None else np.asarray(p_ref, float)
    return prob.damped_at(p0)
