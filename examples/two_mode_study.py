"""Thesis two-mode study, section 5.2.2, equations (5.6)-(5.9).

Prints: the range of Gamma_12 allowed by positive definiteness of Gamma; the collocated FRF y1/u and
its RMS with the poles held fixed (5.7); the pole/zero flip under a small Omega_12 coupling (5.9);
and the structured-uncertainty envelope of y1/u.  Usage: ``python two_mode_study.py [outdir]``
(PNG figures are saved in ``outdir`` when given).  Runs headless in a few seconds.
"""
import sys

import numpy as np
from scipy.optimize import least_squares

import sdctrl as sd

C = np.array([[1.0, 1.0], [2.0, -1.0], [-2.0, 0.0]])
B = np.array([[1.0], [1.0]])
OM0 = np.diag([1.0, 1.21])
GA0 = np.diag([0.04, 0.022])


def model(Omega, Gamma):
    return sd.NormalModeModel(Omega=Omega, Gamma=Gamma, cphi=C, phib=B,
                           sensors=["y1", "y2", "y3"], actuators=["u"])


def poles(Omega, Gamma):
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Omega, -Gamma]])
    ev = np.linalg.eigvals(A)
    ev = ev[ev.imag > 0]
    return ev[np.argsort(ev.imag)]


def fixed_pole_model(g12):
    """(5.7): Gamma_12 = g12 with dGamma_1,2 and dOmega_1,2 adjusted to keep the poles fixed."""
    p0 = poles(OM0, GA0)

    def res(x):
        p = poles(OM0 + np.diag(x[:2]), GA0 + np.diag(x[2:]) + g12 * np.array([[0, 1], [1, 0]]))
        return np.concatenate([(p - p0).real, (p - p0).imag]) * 1e3
    x = least_squares(res, np.zeros(4), xtol=1e-14, ftol=1e-14).x
    return OM0 + np.diag(x[:2]), GA0 + np.diag(x[2:]) + g12 * np.array([[0, 1], [1, 0]])


def h2_rms(Omega, Gamma, out=0):
    """RMS of output ``out`` for unit white noise on u (H2 norm, all frequencies)."""
    from scipy.linalg import solve_continuous_lyapunov
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Omega, -Gamma]])
    Bs = np.vstack([np.zeros((2, 1)), B])
    Cs = np.hstack([C[out:out + 1], np.zeros((1, 2))])
    X = solve_continuous_lyapunov(A, -Bs @ Bs.T)
    return float(np.sqrt((Cs @ X @ Cs.T)[0, 0]))


def zeros_siso(Omega, Gamma, out):
    """Transmission zeros of y_out/u (roots of c adj(s^2 I + Gamma s + Omega) b)."""
    c, b = C[out], B[:, 0]
    # adj of [[a, b12],[b12, d]] = [[d, -b12],[-b12, a]]; entries are quadratics in s
    q = lambda i, j: np.array([1.0 if i == j else 0.0, Gamma[i, j], Omega[i, j]])
    adj = [[q(1, 1), -q(0, 1)], [-q(1, 0), q(0, 0)]]
    num = sum(c[i] * adj[i][j] * b[j] for i in range(2) for j in range(2))
    return np.roots(num) if np.any(num) else np.array([])


def main(outdir=None):
    g_pd = sd.robust.psd_gamma_bound(GA0)[0, 1]
    print(f"(5.7) Gamma_12 range for Gamma >= 0: [-{g_pd:.4f}, {g_pd:.4f}] "
          f"(sqrt(0.04*0.022); the thesis text prints 0.3)")
    f = np.linspace(0.12, 0.22, 401)
    p0 = poles(OM0, GA0)
    rms0 = h2_rms(OM0, GA0)
    curves = {}
    print(f"{'Gamma_12':>9} {'max pole shift':>14} {'normal freq shift %':>20} "
          f"{'zero damping':>12} "
          f"{'RMS y1/u':>9} {'RMS change %':>12}")
    for g12 in (-0.999 * g_pd, 0.0, 0.999 * g_pd):
        Om, Ga = fixed_pole_model(g12)
        m = model(Om, Ga).to_statespace()
        curves[g12] = sd.FRF.from_system(m, f).H[:, 0, 0]
        z = zeros_siso(Om, Ga, 0)
        zz = z[np.argmax(z.imag)]
        fshift = 100 * (np.sqrt(np.linalg.eigvalsh(Om)) / np.sqrt([1.0, 1.21]) - 1)
        r = h2_rms(Om, Ga)
        print(f"{g12:9.4f} {np.max(np.abs(poles(Om, Ga) - p0)):14.2e} "
              f"{np.max(np.abs(fshift)):20.4f} {-zz.real / abs(zz):12.4f} {r:9.4f} "
              f"{100 * (r / rms0 - 1):12.2f}")
    lo, hi = curves[-0.999 * g_pd], curves[0.999 * g_pd]
    print("collocated y1/u: max |H| ratio between extreme cases "
          f"{np.max(np.abs(lo) / np.abs(hi)):.2f}"
          f" / {np.max(np.abs(hi) / np.abs(lo)):.2f} (near the zero at "
          f"{f[np.argmin(np.abs(curves[0.0]) + 1e9 * ((f < 0.16) | (f > 0.175)))]:.4f} Hz)")

    print("\n(5.9) Omega_12 coupling, mode frequencies and proportional damping held fixed")
    print(f"{'Omega_12':>9} {'pole 1 Hz':>9} {'pole 2 Hz':>9}   "
          "zeros of y1/u, y2/u, y3/u (Hz, between poles?)")
    for c12 in (0.0, 0.01, 0.02, 0.05):
        d1 = (0.21 - np.sqrt(0.21 ** 2 - 4 * c12 ** 2)) / 2
        Om = np.array([[1 + d1, c12], [c12, 1.21 - d1]])
        lam, V = np.linalg.eigh(Om)
        Ga = V @ np.diag(2 * np.array([0.02, 0.01]) * np.sqrt(lam)) @ V.T
        fp = np.abs(poles(Om, Ga)) / (2 * np.pi)
        txt = []
        for out in range(3):
            z = zeros_siso(Om, Ga, out)
            zf = np.abs(z[z.imag >= 0]) / (2 * np.pi)
            zf = zf[np.abs(z[z.imag >= 0].imag) > 1e-9] if zf.size else zf
            between = [bool(fp[0] < x < fp[1]) for x in zf]
            txt.append(", ".join(f"{x:.4f}{'*' if bb else ''}" for x, bb in zip(zf, between))
                       or "-")
        print(f"{c12:9.3f} {fp[0]:9.4f} {fp[1]:9.4f}   " + " | ".join(txt))
    print("(* = zero between the two poles: a change of * for a sensor is a pole/zero flip)")

    um = model(OM0, GA0).uncertain(dGamma=sd.robust.psd_gamma_bound(GA0, 0.999))
    env = um.frf_envelope(f, n_samples=40, seed=0)
    k = np.argmin(np.abs(env["nominal"][:, 0, 0]) + 1e9 * ((f < 0.16) | (f > 0.175)))
    print(f"\nuncertain model, Gamma_12 within the PD bound ({um.blocks}): y1/u at the nominal "
          f"zero {f[k]:.4f} Hz spans |H| in [{env['mag_min'][k, 0, 0]:.3f}, "
          f"{env['mag_max'][k, 0, 0]:.3f}] "
          f"(nominal {abs(env['nominal'][k, 0, 0]):.3f})")
    if outdir:
        import os

        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        os.makedirs(outdir, exist_ok=True)
        fig, ax = plt.subplots()
        for g12, st in zip(sorted(curves), ["-", "--", ":"]):
            ax.semilogy(f, np.abs(curves[g12]), st, label=f"Gamma_12={g12:.4f}")
        ax.set_xlabel("frequency (rad/s / 2pi)")
        ax.set_ylabel("|y1/u|")
        ax.legend()
        fig.savefig(os.path.join(outdir, "two_mode_collocated.png"), dpi=80)
        plt.close(fig)
        print(f"saved {os.path.join(outdir, 'two_mode_collocated.png')}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
