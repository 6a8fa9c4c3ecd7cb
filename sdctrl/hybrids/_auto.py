"""The hybrid's residual representation chosen from the test itself (``residual="auto"``).

A hybrid model (5.1) serves predictions at inputs and outputs the test did not have
(untested shakers and sensors, D-struts, 5.3-5.4).  Which representation of what lies
outside the measured modes predicts them best -- the FE modes with residual terms fitted to
the test (``"identified"``), the test's own residual dynamics kept at the tested I/O
(``"tested"``), or the thesis's FE modes alone (``"fe"``) -- depends on the structure and on
how wrong its FE model is, so it is decided on the test's own channels by cross-validation:

- *leave-one-actuator-out*: each candidate is built from the test without actuator ``j``
  (:func:`sdctrl.modal._operations.io_kept`), predicts that actuator's column as an untested
  shaker (:meth:`~sdctrl.hybrids.HybridModel.with_io` with ``b`` its FE load), and is scored
  by the logLS (3.12) of that prediction against the identified model's own column over the
  band;
- *leave-one-sensor-out* when the test has a single actuator (or its actuators are not
  placed on the FE model): the held-out sensor is predicted as an untested output
  (``with_io(c=...)``);
- with one sensor and one actuator nothing can be held out: the candidate closest to the
  identified model at the tested I/O is kept (``"nominal"``).

At most :data:`MAX_FOLDS` channels are held out (evenly spread over the test's list).  The
candidate of lowest mean held-out score wins; candidates within :data:`TIE` of it predict
alike (``"identified"`` and ``"tested"`` share their FE modes away from the tested I/O, so
their held-out predictions coincide), and so do those it does not beat on every fold (with
two to six folds a difference of the means that the folds do not agree on is their
scatter: on a held-out structure at 1% noise ``"fe"`` was 3.8% below ``"identified"`` on
the mean, worse on one fold of three, and choosing it made the nominal model 3.7x the
identified one's); among them the one closest to the identified model at the tested I/O
is kept (:func:`pick`).  The scores are recorded on the model
(``construction.residual``: :class:`~sdctrl.hybrids._hybrid_records.ResidualChoice`).
"""

from __future__ import annotations

import numpy as np

from sdctrl.modal._operations import io_kept
from sdctrl.updating._costs import logls
from sdctrl.hybrids._hybrid_basis import band_lines
from sdctrl.hybrids._predictions import with_static

__all__ = ["MAX_FOLDS", "TIE", "choose_residual", "has_tested", "held_out_scores", "pick",
           "reference_lines"]

#: most channels held out (one fold each)
MAX_FOLDS = 6
#: relative margin within which two candidates' held-out scores count as equal
TIE = 0.02
#: candidates whose held-out predictions are another's by construction: away from the tested
#: I/O (``with_io`` drops the tested sensors' offsets, ``E``, ``F`` and the residual
#: dynamics of the tested inputs) a ``"tested"`` hybrid is its ``"identified"`` one, same
#: shapes, frequencies and damping; the folds build the latter only
SAME_PREDICTIONS = {"tested": "identified"}


def has_tested(nm) -> bool:
    """Whether ``nm`` carries residual terms for ``residual="tested"`` (E, F or residual
    dynamics)."""
    return not (nm.E is None and nm.F is None and nm.residual is None)


def _held_out_input(m, loads, response, j):
    """``m.with_io(b=loads[:, [j]])``, its static correction (2.21) made from column ``j``
    of ``response`` (``K^-1 loads``) when given instead of a solve of its own."""
    b = loads[:, [j]]
    if m.static_ready:
        m = with_static(m, b, response=_columns(response, [j]))
    return m.with_io(b=b, static=False)


def _columns(response, cols):
    """Columns ``cols`` of ``response`` (None stays None)."""
    return None if response is None else response[:, cols]


def _folds(n: int) -> np.ndarray:
    """Indices of the held-out channels: all of ``n``, or :data:`MAX_FOLDS` evenly spread."""
    return np.unique(np.round(np.linspace(0, n - 1, min(n, MAX_FOLDS))).astype(int))


def choose_residual(build, nm, c, loads, full: dict, *, response=None, scores=None):
    """Residual representation of a hybrid by leave-one-out prediction on the test's channels.

    Parameters
    ----------
    build : callable
        ``build(nm_k, c_k, loads_k, names, response_k) -> dict`` of candidate name to
        HybridModel: the candidates ``names`` built from a test without some channels
        (``response_k`` the columns of ``response`` of ``loads_k``, or None).
    nm : NormalModeModel
        The identified model.
    c : ndarray, shape (ns, N)
        Test sensors on the FE DOFs.
    loads : ndarray, shape (N, na), or None
        Test inputs on the FE DOFs (None: not placed).
    full : dict of str to HybridModel
        The candidates built from the whole test.
    response : ndarray, shape (N, na), optional
        ``K^-1 loads``: its columns serve every fold (the builds' static corrections and the
        held-out input's, :func:`~sdctrl.hybrids._predictions.with_static`) instead of a
        solve per fold; None: each solves for its own loads (the same to round-off).
    scores : tuple, optional
        What :func:`held_out_scores` returned for these candidates, when already computed.

    Returns
    -------
    chosen : str
        The kept candidate.
    record : dict
        ``chosen_by``, ``held_out``, ``loo_scores``, ``nominal_scores`` of
        :class:`~sdctrl.hybrids._hybrid_records.ResidualChoice`.
    """
    hz, Href = reference_lines(nm)
    nominal = {k: logls(m.frf(hz).H, Href) for k, m in full.items()}
    names = tuple(dict.fromkeys(SAME_PREDICTIONS.get(k, k) for k in full))
    if scores is None:
        scores = held_out_scores(build, nm, c, loads, names, response=response)
    if scores is None:
        best = min(nominal, key=nominal.get)
        return best, {"chosen_by": "nominal", "held_out": np.zeros(0, int),
                      "loo_scores": {}, "nominal_scores": nominal}
    how, folds, per = scores
    per = {k: per[SAME_PREDICTIONS.get(k, k)] for k in full}
    loo = {k: float(np.mean(v)) for k, v in per.items()}
    return pick(per, nominal), {"chosen_by": how, "held_out": folds, "loo_scores": loo,
                                "nominal_scores": nominal}


def reference_lines(nm):
    """The band's lines (Hz) of the scores and ``nm``'s FRF there (the reference)."""
    w_id = np.sqrt(np.clip(np.diag(nm.Omega), 0, None))
    hz = band_lines(nm, w_id) / (2 * np.pi)
    return hz, nm.frf(hz).H


def held_out_scores(build, nm, c, loads, names, *, response=None):
    """Held-out logLS of the candidates ``names``, one per fold (see
    :func:`choose_residual` for ``build``, ``c``, ``loads`` and ``response``):
    ``(how, folds, {name: [score per fold]})``, or None when nothing can be held out
    (one sensor and one actuator)."""
    hz, Href = reference_lines(nm)
    if loads is not None and nm.na >= 2:
        how, folds = "leave-one-actuator-out", _folds(nm.na)
    elif nm.ns >= 2:
        how, folds = "leave-one-sensor-out", _folds(nm.ns)
    else:
        return None
    per = {k: [] for k in names}
    for j in folds:
        if how == "leave-one-actuator-out":
            rest = np.delete(np.arange(nm.na), j)
            models = build(io_kept(nm, actuators=rest), c, loads[:, rest], names,
                           _columns(response, rest))
            for k, m in models.items():
                per[k].append(logls(_held_out_input(m, loads, response, j).frf(hz).H[:, :, 0],
                                    Href[:, :, j]))
        else:
            rest = np.delete(np.arange(nm.ns), j)
            models = build(io_kept(nm, sensors=rest), c[rest], loads, names, response)
            for k, m in models.items():
                per[k].append(logls(m.with_io(c=c[[j]]).frf(hz).H[:, 0, :], Href[:, j, :]))
    return how, folds, per


def pick(per: dict, nominal: dict) -> str:
    """The kept candidate from its held-out scores per fold and its nominal score.

    The candidate of lowest mean held-out score beats another only when it is lower by more
    than :data:`TIE` and lower on every fold (a sign test over the folds: a difference of
    the means the folds do not agree on is their scatter); the candidates it does not beat
    tie with it, and among them the one closest to the identified model at the tested I/O
    (``nominal``) is kept.

    Parameters
    ----------
    per : dict of str to sequence of float
        Held-out logLS of each candidate, one per fold (the same folds for all).
    nominal : dict of str to float
        logLS of each candidate against the identified model at the tested I/O.

    Returns
    -------
    str

    Examples
    --------
    >>> pick({"a": [1.15, 0.80, 0.82], "b": [1.15, 0.81, 0.71]}, {"a": 1e-5, "b": 0.87})
    'a'
    >>> pick({"a": [0.5, 0.4], "b": [0.2, 0.1]}, {"a": 1e-5, "b": 0.9})
    'b'
    """
    mean = {k: float(np.mean(v)) for k, v in per.items()}
    best = min(mean, key=mean.get)
    a = np.asarray(per[best], float)
    ties = [k for k in per if mean[k] <= (1 + TIE) * mean[best]
            or not np.all(a < np.asarray(per[k], float))]
    return min(ties, key=nominal.get)
