"""PROTOTYPE (issue 11) -- not part of the package; to be moved into
``ema_pipeline.identification`` once the options refactor has landed.

Builds on the package's public functions (pLSCF normal matrix and poles,
stabilization flags, refine_poles, LSFD via finish_identification) and replaces

(a) the fixed highest order by an adaptive one: the pLSCF diagram is computed
    at p0 = default_max_order, then at 2 p, 4 p, ... until the number of
    physical modes selected does not increase any more, or the cap
    ``order_cap(n_lines, n_out, n_in)`` is reached;
(b) the clustering (0.5 % single/average linkage, >= 30 % of all orders) by
    pole *trajectories*: every pole of order n is linked one-to-one (greedy by
    distance) to a pole of order n-1 or n-2 within a distance < 1 in
    d = |df|/(tol_f f) + |dzeta|/(tol_z max zeta) + (1 - MAC(l))/tol_mac;
    a trajectory with >= max(6, frac_min * n_orders) members whose poles are
    physical (window-corrected 0 < zeta < 0.2, frequency inside the band less
    its edges) is a mode, however late it appears; its pole is the median of
    the last half of its members;
(c) close modes: two trajectories that coexist at the same orders are two
    modes (nothing merges them by frequency); after refinement two poles are
    merged only when they coincide within their half-power bands AND their
    LSFD shapes are parallel (MAC > 0.95) -- close modes with different shapes
    stay apart with one reference;
(d) standard deviations from the data (:func:`local_covariance`), no
    calibration factor: see its docstring.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize

from ema_pipeline.data import FRFSet
from ema_pipeline.identification import lsfd as lsfd_mod
from ema_pipeline.identification.core import (
    IdentificationSettings,
    default_max_order,
    finish_identification,
)
from ema_pipeline.identification.plscf import plscf
from ema_pipeline.identification.selection import SelectedPoles
from ema_pipeline.identification.stabilization import pole_to_modal, stabilization


# --------------------------------------------------------------------------- (a) order
def order_cap(n_lines: int, n_out: int, n_in: int, max_poles: int = 480) -> int:
    """Highest denominator order the adaptive search may reach.

    The model of order p has p n_in poles, (p+1) n_in real numerator
    coefficients per output and (p+1) n_in^2 denominator coefficients; the
    2 n_lines real equations of each output must outnumber the numerator
    unknowns at least 2:1 (p <= n_lines / n_in / 2 ... taken as n_lines / 4 for
    one reference), and the companion matrices stay below ``max_poles`` rows.
    """
    by_lines = (n_lines // 2 - 1) // max(n_in, 1) if n_in > 1 else n_lines // 4
    return int(max(2, min(by_lines, max_poles // n_in)))


def diagram_orders(p: int, n_in: int, max_orders: int = 48) -> np.ndarray:
    """Orders of one diagram: every order (every second for one reference, whose
    odd orders add a real pole) up to ``max_orders`` of them, else that many
    evenly spaced in [1, p]; the companion eigenvalues, O(sum n^3), dominate
    the cost at high order."""
    step = 2 if n_in == 1 else 1
    orders = np.arange(step, p + 1, step)
    if orders.size > max_orders:
        pick = np.unique(np.round(np.linspace(0, orders.size - 1, max_orders)).astype(int))
        orders = orders[pick]
    return orders


# --------------------------------------------------------------------------- (b) tracking
def track_poles(order: np.ndarray, orders: np.ndarray, pole: np.ndarray, part: np.ndarray,
                tol_f: float = 0.01, tol_z: float = 0.3, tol_mac: float = 0.05,
                max_gap: int = 2) -> np.ndarray:
    """Trajectory id of every pole (poles sorted by order).

    Pole i of order n links to the end of a trajectory whose last pole is at
    one of the ``max_gap`` previous computed orders, one-to-one, smallest
    distance first, if d < 1 (see module docstring). Memory: one (n_k x n_j)
    distance matrix per order pair.
    """
    fn, _, zeta = pole_to_modal(pole)
    zeta = np.abs(zeta)
    traj = np.full(pole.size, -1)
    starts = np.searchsorted(order, orders)
    ends = np.append(starts[1:], order.size)
    tails: list[int] = []  # pole index of each trajectory's last member
    tail_ord: list[int] = []
    for k, _n in enumerate(orders):
        cur = np.arange(starts[k], ends[k])
        if cur.size == 0:
            continue
        ok_t = [t for t in range(len(tails)) if k - tail_ord[t] <= max_gap]
        if ok_t:
            tp = np.array([tails[t] for t in ok_t])
            df = np.abs(fn[cur][:, None] - fn[tp][None, :]) / (tol_f * fn[tp][None, :])
            zmax = np.maximum(np.maximum(zeta[cur][:, None], zeta[tp][None, :]), 1e-4)
            dz = np.abs(zeta[cur][:, None] - zeta[tp][None, :]) / (tol_z * zmax)
            lc, lt = part[cur], part[tp]
            num = np.abs(lc.conj() @ lt.T) ** 2
            den = np.sum(np.abs(lc) ** 2, 1)[:, None] * np.sum(np.abs(lt) ** 2, 1)[None, :]
            dm = (1 - num / np.maximum(den, 1e-300)) / tol_mac
            d = df + dz + dm
            ii, jj = np.nonzero(d < 1)
            used_c, used_t = set(), set()
            for a in np.argsort(d[ii, jj], kind="stable"):
                i, j = int(ii[a]), int(jj[a])
                if i in used_c or j in used_t:
                    continue
                used_c.add(i)
                used_t.add(j)
                t = ok_t[j]
                traj[cur[i]] = t
                tails[t] = int(cur[i])
                tail_ord[t] = k
        for i in np.flatnonzero(traj[cur] < 0):
            traj[cur[i]] = len(tails)
            tails.append(int(cur[i]))
            tail_ord.append(k)
    return traj


def select_trajectories(order: np.ndarray, pole: np.ndarray, traj: np.ndarray, n_orders: int,
                        band_hz: tuple[float, float], decay: float, frac_min: float = 0.1,
                        min_members: int = 6, edge: tuple[float, float] = (0.005, 0.02),
                        zeta_max: float = 0.2, max_scatter: float = 0.15,
                        ) -> dict[str, np.ndarray]:
    """Physical modes among the trajectories: enough members and physical poles.

    Returns pole (median of the last half of the members), n_members,
    first_order (where the trajectory starts), scatter of fn and zeta.
    """
    need = max(min_members, int(np.ceil(frac_min * n_orders)))
    ids, counts = np.unique(traj, return_counts=True)
    lo, hi = band_hz
    w = hi - lo
    out = {"pole": [], "n_members": [], "first_order": [], "sfn": [], "sz": []}
    for t in ids[counts >= need]:
        m = np.flatnonzero(traj == t)
        tail = m[m.size // 2:]
        rep = np.median(pole[tail].real) + 1j * np.median(pole[tail].imag)
        fn, _, z = pole_to_modal(np.array([rep]), decay)
        if not (rep.real < 0 and 0 < z[0] < zeta_max
                and lo + edge[0] * w < fn[0] < hi - edge[1] * w):
            continue
        f_m, _, z_m = pole_to_modal(pole[tail], decay)
        # settled: over the last half of the trajectory f and zeta of the
        # identified poles scatter by less than max_scatter of the half-power
        # half-width (zeta f) and of zeta
        f_i, _, z_i = pole_to_modal(pole[tail])
        zi = max(float(np.median(z_i)), 1e-6)
        if (np.std(f_i) > max_scatter * zi * np.median(f_i)
                or np.std(z_i) > max_scatter * zi):
            continue
        out["pole"].append(rep)
        out["n_members"].append(m.size)
        out["first_order"].append(int(order[m[0]]))
        out["sfn"].append(np.std(f_m))
        out["sz"].append(np.std(z_m))
    res = {k: np.asarray(v) for k, v in out.items()}
    s = np.argsort(res["pole"].imag) if res["pole"].size else np.zeros(0, int)
    return {k: v[s] for k, v in res.items()}


# --------------------------------------------------------------------------- (d) sigma
def window_correlation(frf: FRFSet, max_lag: int) -> np.ndarray | None:
    """Correlation rho_l (l = 0..max_lag, complex) of the FRF noise between
    lines l apart caused by the response window, or None (independent lines).

    The DFT of w(t) n(t) (white n) has E[N_k conj(N_m)] = s^2 sum_t w_t^2
    exp(-2 pi i (k-m) t / N), so rho_l = DFT(w^2)[l] / sum w^2. Only the
    exponential window is known from the metadata (w = exp(-t/tau) from the
    trigger, t in [0, N/fs)); H1 keeps that correlation (the force spectrum
    of a short impact is smooth).
    """
    acq = frf.acquisition
    if not acq.exp_window_tau_s or not acq.n_samples or not acq.sample_rate_hz:
        return None
    t = np.arange(acq.n_samples) / acq.sample_rate_hz
    w2 = np.exp(-2 * t / acq.exp_window_tau_s)
    r = np.fft.fft(w2) / np.sum(w2)
    return r[: max_lag + 1]


def noise_from_coherence(frf: FRFSet, smooth: int = 7) -> np.ndarray | None:
    """Variance E|dH|^2 (n_out, n_in, n_freq) of H1 from coherence and averages.

    With n_d averages, Gxx (1 - coh) = (1/n_d) sum |X_i - H1 F_i|^2 is the
    residual power of n_d - 1 complex degrees of freedom, and
    var(H1) = sigma_n^2 / (n_d Gff), so the unbiased estimate is
    var(H1) = |H1|^2 (1 - coh) / ((n_d - 1) coh), smoothed over ``smooth``
    lines (it is a chi-square of 2 (n_d - 1) degrees of freedom per line).
    None when the set has no coherence or fewer than 2 averages.
    """
    nd = frf.acquisition.n_averages
    if frf.coherence is None or not nd or nd < 2:
        return None
    coh = np.clip(frf.coherence, 1e-6, 1.0)
    var = np.abs(frf.H) ** 2 * (1 - coh) / ((nd - 1) * coh)
    ker = np.ones(smooth) / smooth
    pad = np.pad(var, [(0, 0), (0, 0), (smooth // 2, smooth // 2)], mode="edge")
    sm = np.apply_along_axis(lambda v: np.convolve(v, ker, mode="valid"), -1, pad)
    floor = 1e-12 * np.max(np.abs(frf.H) ** 2, axis=-1, keepdims=True)
    return np.maximum(sm, floor)


def _design(jw: np.ndarray, lam: np.ndarray, bg: np.ndarray) -> np.ndarray:
    g = 1.0 / (jw[:, None] - lam[None, :])
    gc = 1.0 / (jw[:, None] - np.conj(lam)[None, :])
    cols = np.empty((jw.size, 2 * lam.size + 2 * bg.shape[1]), dtype=complex)
    cols[:, 0 : 2 * lam.size : 2] = g + gc
    cols[:, 1 : 2 * lam.size : 2] = 1j * (g - gc)
    cols[:, 2 * lam.size :: 2] = bg
    cols[:, 2 * lam.size + 1 :: 2] = 1j * bg
    return np.concatenate([cols.real, cols.imag], axis=0)


def _jac(jw: np.ndarray, lam: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(n_ch, 2n, 2m) derivative of the model wrt (sigma_j, omega_j)."""
    m = lam.size
    a = X[:, 0 : 2 * m : 2] + 1j * X[:, 1 : 2 * m : 2]  # (n_ch, m)
    d1 = 1.0 / (jw[:, None] - lam[None, :]) ** 2
    d2 = 1.0 / (jw[:, None] - np.conj(lam)[None, :]) ** 2
    t1 = d1[None] * a[:, None, :]
    t2 = d2[None] * np.conj(a)[:, None, :]
    J = np.empty((a.shape[0], jw.size, 2 * m), dtype=complex)
    J[:, :, 0::2] = -(t1 + t2)
    J[:, :, 1::2] = 1j * (t1 - t2)
    return np.concatenate([J.real, J.imag], axis=1)


def _wls(A: np.ndarray, Y: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per-channel weighted LS: A (2n, K), Y (n_ch, 2n), w (n_ch, 2n).
    Returns X (n_ch, K), Q (n_ch, 2n, K) orthonormal basis of the weighted design,
    weighted residual (n_ch, 2n)."""
    Aw = A[None] * w[:, :, None]
    sc = np.max(np.abs(Aw), axis=1, keepdims=True)
    sc[sc == 0] = 1
    Q, R = np.linalg.qr(Aw / sc)
    Yw = Y * w
    qy = np.einsum("cnk,cn->ck", Q, Yw)
    X = np.linalg.solve(R, qy[..., None])[..., 0] / sc[:, 0, :]
    res = Yw - np.einsum("cnk,ck->cn", Q, qy)
    return X, Q, res


def local_covariance(freq_hz: np.ndarray, H: np.ndarray, poles: np.ndarray, r: int,
                     var: np.ndarray | None, rho: np.ndarray | None, df_hz: float,
                     half_width: float = 12.0, min_lines: int = 40,
                     n_gn: int = 8) -> tuple[complex, np.ndarray, float]:
    """Weighted local fit of mode r and the covariance of its (sigma, omega_d).

    Local band and model as in :func:`lsfd.refine_poles` (the poles whose
    half-power band reaches into f_r +- 12 half-power bandwidths, a complex
    quadratic background per channel). Noise variance per channel and line:
    ``var`` (from coherence and averages) where given, otherwise from the
    residual of the fit, var_ck = a_c + b_c |H_ck|^2 fitted by NNLS to |e_ck|^2
    and scaled by the degrees of freedom 2n / (2n - K) (K linear terms per
    channel plus the channel's share of the pole parameters), re-estimated
    after one weighted solve; where ``var`` (from coherence and averages) is
    given, the larger of the two (coherence sees only the random error, the
    residual also the bias: leakage, force noise, model error). The poles are
    re-solved by Gauss-Newton in those weights (so the estimate is the
    weighted LS whose covariance follows).
    Covariance: sandwich F^-1 G F^-1 with F = sum_c Jt_c^T Jt_c and
    G = sum_c Jt_c^T C Jt_c, Jt_c = (I - P_c) W_c J_c the projected weighted
    Jacobian and C the correlation of the weighted noise between lines
    (``rho``, from the window; identity when None): first-order
    propagation of the noise through the least-squares fit. No factor.

    Returns the refined pole, its 2x2 covariance and std(sigma)/sigma.
    """
    f_r = poles.imag / (2 * np.pi)
    hpb = np.abs(poles.real) / np.pi
    width = max(half_width * hpb[r], 0.5 * min_lines * df_hz)
    width = min(width, 0.2 * f_r[r]) if 0.2 * f_r[r] > 5 * df_hz else width
    lo, hi = f_r[r] - width, f_r[r] + width
    sel = (freq_hz >= lo) & (freq_hz <= hi)
    if sel.sum() < 12:
        return poles[r], np.full((2, 2), np.nan), np.inf
    f = freq_hz[sel]
    n = f.size
    jw = 2j * np.pi * f
    members = np.union1d(np.flatnonzero((f_r + hpb > lo) & (f_r - hpb < hi)), [r])
    k = int(np.flatnonzero(members == r)[0])
    x = (f - f_r[r]) / width
    bg = np.stack([np.ones_like(x), x, x**2], axis=1).astype(complex)
    Hl = H[:, sel]
    Y = np.concatenate([Hl.real, Hl.imag], axis=1)  # (n_ch, 2n)
    lam = poles[members].copy()
    m = lam.size
    n_ch = Y.shape[0]
    K = 2 * m + 2 * bg.shape[1]

    def noise_w(lam_: np.ndarray, w_: np.ndarray) -> np.ndarray:
        A = _design(jw, lam_, bg)
        _, _, res = _wls(A, Y, w_)
        e = res / w_
        e2 = e[:, :n] ** 2 + e[:, n:] ** 2
        fit = Y - e
        h2 = fit[:, :n] ** 2 + fit[:, n:] ** 2
        dof = 2 * n / max(2 * n - K - 2 * m / n_ch, 1)
        s2 = np.empty_like(e2)
        for c in range(n_ch):
            sc = max(np.max(h2[c]), 1e-300)
            coef, _ = optimize.nnls(np.stack([np.ones(n), h2[c] / sc], 1), e2[c])
            v = (coef[0] + coef[1] * h2[c] / sc) * dof
            s2[c] = np.maximum(v, max(np.mean(e2[c]) * dof * 1e-3, 1e-300))
        if var is not None:  # random error from coherence; the residual also shows bias
            s2 = np.maximum(var[:, sel], s2)
        sd = np.sqrt(s2 / 2)  # per real/imag component
        return 1.0 / np.concatenate([sd, sd], axis=1)

    def normal(lam_: np.ndarray, w_: np.ndarray) -> tuple[np.ndarray, ...]:
        A = _design(jw, lam_, bg)
        X, Q, res = _wls(A, Y, w_)
        J = _jac(jw, lam_, X) * w_[:, :, None]
        Jt = J - np.einsum("cnk,ckp->cnp", Q, np.einsum("cnk,cnp->ckp", Q, J))
        F = np.einsum("cnp,cnq->pq", Jt, Jt)
        g = np.einsum("cnp,cn->p", Jt, res)
        return F, g, float(np.sum(res**2)), Jt

    w = np.ones((n_ch, 2 * n)) / np.maximum(np.std(Y, axis=1, keepdims=True), 1e-300)
    w = noise_w(lam, w)
    w = noise_w(lam, w)
    F, g, cost, Jt = normal(lam, w)
    for _ in range(n_gn):
        try:
            step = np.linalg.solve(F + 1e-9 * np.diag(np.diag(F)), g)
        except np.linalg.LinAlgError:
            break
        th = np.empty(2 * m)
        th[0::2], th[1::2] = -lam.real, lam.imag
        th = th + step
        if np.any(th[0::2] <= 0):
            break
        lam_t = -th[0::2] + 1j * th[1::2]
        F_t, g_t, cost_t, Jt_t = normal(lam_t, w)
        if cost_t > cost:
            break
        lam, F, g, cost, Jt = lam_t, F_t, g_t, cost_t, Jt_t
    if abs(lam[k] - poles[r]) > 0.5 * abs(poles[r].real) + 2 * np.pi * df_hz:
        lam = poles[members].copy()  # wandered off: keep the start, covariance there
        F, g, cost, Jt = normal(lam, w)
    try:
        Finv = np.linalg.inv(F)
    except np.linalg.LinAlgError:
        Finv = np.linalg.pinv(F)
    if rho is not None:
        lag = np.abs(np.arange(n)[:, None] - np.arange(n)[None, :])
        lagc = np.minimum(lag, rho.size - 1)
        sign = np.sign(np.arange(n)[:, None] - np.arange(n)[None, :])
        rr = rho[lagc]
        rr = np.where(sign < 0, np.conj(rr), rr) * (lag < rho.size)
        Cr = np.block([[rr.real, -rr.imag], [rr.imag, rr.real]])
        G = np.einsum("cnp,cnq->pq", Jt, Cr @ Jt)
        cov = Finv @ G @ Finv
    else:
        cov = Finv
    c = cov[2 * k : 2 * k + 2, 2 * k : 2 * k + 2]
    rel = float(np.sqrt(max(c[0, 0], 0.0)) / abs(lam[k].real))
    return lam[k], c, rel


# --------------------------------------------------------------------------- driver
def identify_proto(frf: FRFSet, band_hz: tuple[float, float] | None = None,
                   max_order: int | None = None, *, frac_min: float = 0.1,
                   max_rel_sigma: float = 0.25, verbose: bool = False):
    """Prototype of the issue-11 identification; returns an IdentificationResult."""
    f = frf.freq_hz
    lo, hi = (float(f[min(5, f.size - 2)]), float(f[-1])) if band_hz is None else band_hz
    sub = frf.band(lo, hi)
    freq = sub.freq_hz
    n_out, n_in, n_freq = sub.H.shape
    decay = float(frf.acquisition.window_decay_rate)
    rms = np.sqrt(np.mean(np.abs(sub.H) ** 2, axis=(1, 2)))
    Hn = sub.H / rms[:, None, None]
    cap = order_cap(n_freq, n_out, n_in)
    p = min(default_max_order(n_in, n_freq), cap) if max_order is None else int(max_order)
    Hc = sub.H.reshape(n_out * n_in, n_freq)
    history = []
    best = None
    while True:
        orders = diagram_orders(p, n_in)
        try:
            poles = plscf(freq, Hn, max_order=p, orders=orders)
        except np.linalg.LinAlgError:  # normal equations too ill-conditioned: stop growing
            if best is None:
                raise
            break
        traj = track_poles(poles.order, poles.orders, poles.pole, poles.participation)
        sel = select_trajectories(poles.order, poles.pole, traj, orders.size, (lo, hi),
                                  decay, frac_min=frac_min)
        sel = _merge_coincident(sel)
        rel = _significance(freq, Hc, sel["pole"])
        sel = {k2: v[rel < max_rel_sigma] for k2, v in sel.items()}
        n_modes = sel["pole"].size
        history.append((p, n_modes))
        if verbose:
            print(f"  order {p}: {n_modes} modes")
        gain = best is None or n_modes > best[0]["pole"].size
        if gain:
            best = (sel, traj, poles, orders)
        # stop when the larger model found the same number of modes and had room
        # to spare (>= 3 pole pairs per mode found + 10), or at the cap; a drop
        # in the count (trajectories not settled yet) means: grow further
        room = (p * n_in) / 2 >= 3 * n_modes + 10
        same = len(history) >= 2 and n_modes == history[-2][1]
        if max_order is not None or p >= cap or (same and room):
            break
        p = min(2 * p, cap)
    sel, traj, poles, orders = best
    p = int(orders[-1])
    stab = stabilization(poles, decay)
    stab = type(stab)(**{**stab.__dict__, "cluster": traj})
    pole_id = sel["pole"]
    # (d) noise model, local weighted refinement with covariance
    var_all = noise_from_coherence(sub)
    var = None if var_all is None else var_all.reshape(n_out * n_in, n_freq)
    rho = window_correlation(sub, max_lag=n_freq)
    pole_id = pole_id.copy()
    m = pole_id.size
    covs = np.full((m, 2, 2), np.nan)
    rel = np.full(m, np.inf)
    for r in range(m):
        lam, c, rl = local_covariance(freq, Hc, pole_id, r, var, rho, sub.df_hz)
        pole_id[r], covs[r], rel[r] = lam, c, rl
    ok = rel < max_rel_sigma
    pole_id, covs = pole_id[ok], covs[ok]
    sel = {k2: v[ok] for k2, v in sel.items()}
    pole_id, keep = _dedup(freq, Hc, pole_id, sub.quantity)
    covs = covs[keep]
    sel = {k2: v[keep] for k2, v in sel.items()}
    fn_std, zeta_std = lsfd_mod.modal_std(pole_id + decay, covs)
    order_s = np.argsort(pole_id.imag)
    pole_id, fn_std, zeta_std = pole_id[order_s], fn_std[order_s], zeta_std[order_s]
    sel = {k2: v[order_s] for k2, v in sel.items()}
    selected = SelectedPoles(pole=pole_id, cluster=np.arange(pole_id.size),
                             n_members=sel["n_members"].astype(int),
                             scatter_fn_hz=fn_std, scatter_zeta=zeta_std)
    settings = IdentificationSettings(
        method="plscf-proto", band_hz=(lo, hi), max_order=p, orders=orders, dt_s=poles.dt,
        weighting="none", window_decay_rate=decay, tol_freq=0.01, tol_zeta=0.3, tol_mac=0.05,
        min_fraction=frac_min, refine=True, lower_residual=True, upper_residual=True,
        expect_hz=None, uncertainty="data noise propagated (prototype)")
    res = finish_identification(sub, pole_id, decay=decay, refine=False, lower_residual=True,
                                upper_residual=True, stab=stab, selected=selected,
                                settings=settings)
    res.extras.update({"order_history": history})  # type: ignore[dict-item]
    return res


def _merge_coincident(sel: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Drop a trajectory whose pole lies within 0.2 of a decay rate of a longer
    one's (numerically the same pole, e.g. a trajectory broken by a gap)."""
    pole = sel["pole"]
    keep = np.ones(pole.size, bool)
    for a in np.argsort(-sel["n_members"], kind="stable"):
        if not keep[a]:
            continue
        near = np.abs(pole - pole[a]) < 0.2 * np.abs(pole[a].real)
        near[a] = False
        keep &= ~near
    return {k: v[keep] for k, v in sel.items()}


def _significance(freq: np.ndarray, Hc: np.ndarray, pole: np.ndarray) -> np.ndarray:
    """std(sigma)/sigma of each pole from the package's local LS fit (no factor)."""
    if pole.size == 0:
        return np.zeros(0)
    try:
        return lsfd_mod.pole_significance(freq, Hc, pole)
    except np.linalg.LinAlgError:
        out = np.empty(pole.size)
        for r in range(pole.size):
            try:
                out[r] = lsfd_mod.pole_significance(freq, Hc, pole[r:r + 1])[0]
            except np.linalg.LinAlgError:
                out[r] = np.inf
        return out


def _dedup(freq: np.ndarray, Hc: np.ndarray, pole: np.ndarray,
           quantity: str) -> tuple[np.ndarray, np.ndarray]:
    """Merge refined poles that coincide within their half-power bands and whose
    LSFD shapes are parallel (MAC > 0.95); keeps close modes with different shapes."""
    keep = np.ones(pole.size, bool)
    if pole.size < 2:
        return pole, keep
    try:
        fit = lsfd_mod.lsfd(freq, Hc, pole, quantity)
    except np.linalg.LinAlgError:
        return pole, keep
    M = lsfd_mod.mac(fit.a.T)
    s = np.argsort(pole.imag)
    for a, b in zip(s[:-1], s[1:], strict=True):
        if not keep[a]:
            continue
        close = abs(pole[a].imag - pole[b].imag) < 0.5 * (abs(pole[a].real) + abs(pole[b].real))
        if close and M[a, b] > 0.95:
            # keep the one with the larger response
            na, nb = np.linalg.norm(fit.a[a]), np.linalg.norm(fit.a[b])
            keep[b if na >= nb else a] = False
    return pole[keep], keep
