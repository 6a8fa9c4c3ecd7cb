"""Block structure of a structured singular value problem and its D-G scalings (internal
representation used by :mod:`sdctrl.robust.mu._upper`).

A structure is a list of blocks ``"real"`` (repeated real scalar ``delta I_r``), ``"complex"``
(repeated complex scalar) or ``"full"`` (full complex ``r x r``).  The scalings commuting with
it are ``D = F F^H`` (``F`` block lower triangular: full ``r x r`` for repeated scalars, ``d I``
for full blocks) and ``G = F Gh F^H`` (``Gh`` Hermitian on the real blocks, zero elsewhere); a
real parameter vector holds the log of the diagonal of ``F``, its strictly lower part and
``Gh``, so that BFGS can search them unconstrained.  Blocks of equal size and kind are handled
together (vectorised); structures of scalar blocks only get a fully vectorised index map.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["BLOCK_KINDS", "BlockStructure", "Factored"]

BLOCK_KINDS = ("real", "complex", "full")


@dataclass(frozen=True, eq=False)
class Factored:
    """``M = L @ K @ R`` (``L``: (N, p), ``K``: (p, m), ``R``: (m, N)); ``L = R = None`` means
    ``M = K``.

    Parameters
    ----------
    K : ndarray
        Core matrix (the whole ``M`` when ``L`` and ``R`` are None).
    L, R : ndarray or None
        Output and input factors.
    """

    K: np.ndarray
    L: np.ndarray | None = None
    R: np.ndarray | None = None

    @property
    def N(self) -> int:
        """Number of channels."""
        return self.K.shape[0] if self.L is None else self.L.shape[0]

    @property
    def low_rank(self) -> bool:
        """Whether the factored path (small core) is used."""
        return self.L is not None and self.K.shape[0] + self.K.shape[1] < self.N

    def dense(self) -> np.ndarray:
        """``M`` as an (N, N) array."""
        return self.K if self.L is None else self.L @ self.K @ self.R


@dataclass(frozen=True, eq=False)
class BlockStructure:
    """Block-diagonal uncertainty structure, blocks in channel order.

    Parameters
    ----------
    sizes : tuple of int
        Size ``r`` of each block.
    kinds : tuple of str
        ``"real"``, ``"complex"`` (repeated scalars ``delta I_r``) or ``"full"`` (``r x r``).
    """

    sizes: tuple
    kinds: tuple
    groups: list = field(init=False, repr=False)
    nv: int = field(init=False, repr=False)
    scalar: tuple | None = field(init=False, repr=False)

    def __post_init__(self):
        sizes = tuple(int(r) for r in self.sizes)
        kinds = tuple(str(k) for k in self.kinds)
        if len(sizes) != len(kinds) or any(r < 1 for r in sizes) or any(
                k not in BLOCK_KINDS for k in kinds):
            raise ValueError(f"blocks must be positive sizes with kinds in {BLOCK_KINDS}")
        object.__setattr__(self, "sizes", sizes)
        object.__setattr__(self, "kinds", kinds)
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(int)
        groups, off = [], 0
        for key in sorted(set(zip(sizes, kinds))):
            r, kind = key
            ids = np.array([i for i, s in enumerate(zip(sizes, kinds)) if s == key])
            idx = starts[ids][:, None] + np.arange(r)[None, :]          # (K, r) channels
            nf = 1 if kind == "full" else r * r
            ng = r * r if kind == "real" else 0
            il = np.tril_indices(r, -1)
            groups.append({"r": r, "kind": kind, "blocks": ids, "idx": idx, "nf": nf, "ng": ng,
                           "off": off, "il": il, "m": len(il[0]), "ar": np.arange(r)})
            off += len(ids) * (nf + ng)
        object.__setattr__(self, "groups", groups)
        object.__setattr__(self, "nv", off)
        scalar = None
        if all(r == 1 for r in sizes):           # parameter index of each channel's scalings
            s_idx, g_idx, g_chan = np.zeros(len(sizes), int), [], []
            for g in groups:
                step = g["nf"] + g["ng"]
                s_idx[g["idx"][:, 0]] = g["off"] + step * np.arange(len(g["blocks"]))
                if g["ng"]:
                    g_chan += list(g["idx"][:, 0])
                    g_idx += list(g["off"] + 1 + step * np.arange(len(g["blocks"])))
            scalar = (s_idx, np.array(g_idx, int), np.array(g_chan, int))
        object.__setattr__(self, "scalar", scalar)

    @classmethod
    def real_repeated(cls, reps, eps: float = 0.0) -> BlockStructure:
        """Repeated real scalars, followed by their complex copies when ``eps > 0``.

        Parameters
        ----------
        reps : sequence of int
            Repetition of each real scalar.
        eps : float
            Regularisation ``delta + eps delta_c``: complex copies are appended when positive
            (the matrix then is ``[[M, M], [eps M, eps M]]``).

        Returns
        -------
        BlockStructure
        """
        reps = tuple(int(r) for r in reps)
        kinds = ("real",) * len(reps) + (("complex",) * len(reps) if eps > 0 else ())
        return cls(reps + (reps if eps > 0 else ()), kinds)

    @property
    def N(self) -> int:
        """Number of channels."""
        return int(sum(self.sizes))

    @property
    def block_of_channel(self) -> np.ndarray:
        """Block index of every channel."""
        return np.repeat(np.arange(len(self.sizes)), self.sizes)

    # ---------------------------------------------------------------- scalings
    def start(self, d=None) -> np.ndarray:
        """Parameter vector of the scalings ``D = diag(d_i I)``, ``G = 0``.

        Parameters
        ----------
        d : array_like, optional
            Positive scaling of each block (default 1).

        Returns
        -------
        ndarray (nv,)
        """
        x = np.zeros(self.nv)
        if d is None:
            return x
        s = 0.5 * np.log(np.asarray(d, float))
        for g in self.groups:
            K, r = len(g["blocks"]), g["r"]
            p = np.zeros((K, g["nf"] + g["ng"]))
            p[:, :1 if g["kind"] == "full" else r] = s[g["blocks"]][:, None]
            x[g["off"]:g["off"] + p.size] = p.ravel()
        return x

    def unpack(self, x):
        """Scalings of each group of equal blocks from the parameter vector.

        ``D = F F^H`` with ``F`` lower triangular (log of its diagonal and its strictly lower
        part are parameters), ``G = F Gh F^H`` with ``Gh`` Hermitian (real blocks only).

        Parameters
        ----------
        x : ndarray (nv,)
            Parameter vector.

        Returns
        -------
        list of tuple
            ``(F, F^-1, Gh)`` per group, arrays (K, r, r) or (K,) for scalar blocks; ``Gh``
            is None on complex and full blocks.
        """
        out = []
        for g in self.groups:
            K, r, nf, ng = len(g["blocks"]), g["r"], g["nf"], g["ng"]
            p = x[g["off"]:g["off"] + K * (nf + ng)].reshape(K, nf + ng)
            if r == 1:
                F = np.exp(p[:, 0])
                out.append((F, 1.0 / F, p[:, 1] if ng else None))
                continue
            if g["kind"] == "full":
                e = np.exp(p[:, 0])
                eye = np.eye(r)
                out.append((e[:, None, None] * eye, (1 / e)[:, None, None] * eye, None))
                continue
            il, m, ar = g["il"], g["m"], g["ar"]
            F = np.zeros((K, r, r), complex)
            F[:, ar, ar] = np.exp(p[:, :r])
            F[:, il[0], il[1]] = p[:, r:r + m] + 1j * p[:, r + m:r + 2 * m]
            Fi = np.linalg.inv(F)
            Gh = None
            if ng:
                q = p[:, nf:]
                Gh = np.zeros((K, r, r), complex)
                Gh[:, ar, ar] = q[:, :r]
                Gh[:, il[0], il[1]] = q[:, r:r + m] + 1j * q[:, r + m:r + 2 * m]
                Gh[:, il[1], il[0]] = np.conj(Gh[:, il[0], il[1]])
            out.append((F, Fi, Gh))
        return out

    def apply(self, mats, X, which: int, herm: bool = False) -> np.ndarray:
        """Block-diagonal product ``B @ X``.

        Parameters
        ----------
        mats : list
            Output of :meth:`unpack`.
        X : ndarray (N,) or (N, q)
            Operand.
        which : int
            0: ``F``, 1: ``F^-1``, 2: ``Gh`` (zero on blocks without ``G``).
        herm : bool
            Use ``B^H``.

        Returns
        -------
        ndarray
        """
        Y = np.zeros(X.shape, complex)
        for g, m in zip(self.groups, mats):
            B = m[which]
            if B is None:
                continue
            if g["r"] == 1:
                i0 = g["idx"][:, 0]
                Y[i0] = (B if X.ndim == 1 else B[:, None]) * X[i0]
                continue
            if herm:
                B = np.conj(np.swapaxes(B, 1, 2))
            if X.ndim == 1:
                Y[g["idx"]] = (B @ X[g["idx"]][..., None])[..., 0]
            else:
                Y[g["idx"]] = B @ X[g["idx"]]
        return Y

    def gradient(self, mats, xv, u, yv, v) -> np.ndarray:
        """Gradient of the largest eigenvalue of (1) with respect to the parameters.

        In scaled coordinates, ``d lambda = Re tr(A dF) + Re tr(C dGh)`` blockwise with
        ``A = 2 (u yv^H - xv v^H)^H F^-1`` and ``C = j (u xv^H - xv u^H)``.

        Parameters
        ----------
        mats : list
            Output of :meth:`unpack`.
        xv : ndarray (N,)
            Unit eigenvector of the scaled matrix.
        u, yv, v : ndarray (N,)
            ``Mh xv``, ``u - j Gh xv`` and ``Mh^H yv``.

        Returns
        -------
        ndarray (nv,)
        """
        grad = np.zeros(self.nv)
        for g, (F, Fi, _Gh) in zip(self.groups, mats):
            K, r, nf, ng = len(g["blocks"]), g["r"], g["nf"], g["ng"]
            if r == 1:
                i0 = g["idx"][:, 0]
                xi, ui, yi, vi = xv[i0], u[i0], yv[i0], v[i0]
                A = 2 * np.conj(ui * np.conj(yi) - xi * np.conj(vi)) * Fi
                gk = np.zeros((K, nf + ng))
                gk[:, 0] = np.real(A) * F
                if ng:
                    gk[:, 1] = -2 * np.imag(ui * np.conj(xi))
                grad[g["off"]:g["off"] + gk.size] = gk.ravel()
                continue
            xi, ui, yi, vi = (a[g["idx"]] for a in (xv, u, yv, v))          # (K, r)
            P = ui[:, :, None] * yi.conj()[:, None, :] - xi[:, :, None] * vi.conj()[:, None, :]
            A = 2 * np.conj(np.swapaxes(P, 1, 2)) @ Fi
            gk = np.zeros((K, nf + ng))
            if g["kind"] == "full":
                gk[:, 0] = np.real(np.einsum("kii->k", A @ F))
            else:
                il, m, ar = g["il"], g["m"], g["ar"]
                gk[:, :r] = np.real(A[:, ar, ar]) * np.real(F[:, ar, ar])
                At = A[:, il[1], il[0]]
                gk[:, r:r + m] = np.real(At)
                gk[:, r + m:r + 2 * m] = -np.imag(At)
                if ng:
                    C = 1j * (ui[:, :, None] * xi.conj()[:, None, :]
                              - xi[:, :, None] * ui.conj()[:, None, :])
                    gk[:, nf:nf + r] = np.real(C[:, ar, ar])
                    Cl = C[:, il[0], il[1]]
                    gk[:, nf + r:nf + r + m] = 2 * np.real(Cl)
                    gk[:, nf + r + m:] = 2 * np.imag(Cl)
            grad[g["off"]:g["off"] + gk.size] = gk.ravel()
        return grad

    def dense_scalings(self, x):
        """The scalings as dense matrices.

        Parameters
        ----------
        x : ndarray (nv,)
            Parameter vector.

        Returns
        -------
        D, G : ndarray (N, N)
        """
        N = self.N
        D = np.zeros((N, N), complex)
        G = np.zeros((N, N), complex)
        for g, (F, _Fi, Gh) in zip(self.groups, self.unpack(x)):
            if g["r"] == 1:
                i0 = g["idx"][:, 0]
                D[i0, i0] = F ** 2
                if Gh is not None:
                    G[i0, i0] = F * Gh * F
                continue
            Fh = np.conj(np.swapaxes(F, 1, 2))
            for k, idx in enumerate(g["idx"]):
                D[np.ix_(idx, idx)] = F[k] @ Fh[k]
                if Gh is not None:
                    G[np.ix_(idx, idx)] = F[k] @ Gh[k] @ Fh[k]
        return D, G

    def params(self, D, G) -> np.ndarray:
        """Parameter vector of dense scalings (the inverse of :meth:`dense_scalings`).

        Parameters
        ----------
        D : ndarray (N, N)
            Hermitian positive definite, block diagonal with the structure (``d I`` on full
            blocks).
        G : ndarray (N, N)
            Hermitian, block diagonal, zero off the real blocks (ignored there).

        Returns
        -------
        ndarray (nv,)
        """
        x = np.zeros(self.nv)
        for g in self.groups:
            r, nf, ng = g["r"], g["nf"], g["ng"]
            p = np.zeros((len(g["blocks"]), nf + ng))
            for k, idx in enumerate(g["idx"]):
                blk = np.ix_(idx, idx)
                Dk = 0.5 * (D[blk] + np.conj(D[blk].T))
                if g["kind"] == "full":
                    p[k, 0] = 0.5 * np.log(np.real(np.trace(Dk)) / r)
                    continue
                F = np.linalg.cholesky(Dk)
                Fi = np.linalg.inv(F)
                p[k, :r] = np.log(np.real(np.diag(F)))
                il, m = g["il"], g["m"]
                p[k, r:r + m], p[k, r + m:nf] = np.real(F[il]), np.imag(F[il])
                if ng:
                    Gh = Fi @ G[blk] @ np.conj(Fi.T)
                    p[k, nf:nf + r] = np.real(np.diag(Gh))
                    p[k, nf + r:nf + r + m] = np.real(Gh[il])
                    p[k, nf + r + m:] = np.imag(Gh[il])
            x[g["off"]:g["off"] + p.size] = p.ravel()
        return x
