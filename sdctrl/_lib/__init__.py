"""Private helpers shared by every package of sdctrl (like scipy's ``_lib``).

- ``validate``: input validation at the public boundary (arguments named in every error);
- ``files``, ``npzfile``: checked paths, atomic writes, defensive plain-array ``.npz`` archives;
- ``statespace``, ``bandint``: state-space FRF kernel, band-limited output covariance;
- ``progress``, ``threads``: the progress-bar policy and scoped BLAS thread limits;
- ``display``: the small text helpers of reprs and reports;
- ``trustregion``, ``triangular``, ``chisquare``: bounded nonlinear least squares, triangular
  solves and chi-square quantiles in numpy (the identification path imports no scipy).

Nothing here is public; each package re-exports what users call.
"""
