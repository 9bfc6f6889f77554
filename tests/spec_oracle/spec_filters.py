"""Clean-room double-precision reference of /work/shared/spec/filters.md.

Written from the spec text only. numpy, float64 throughout.

Shapes: rotations q (F, J, 4) wxyz Hamilton; translations p (F, J, 3).
Every filter works per joint on the time axis (axis 0), vectorised over
joints; nlpm couples the joints through its pose weights.
"""

import math
import numpy as np

# ----------------------------------------------------------------------------
# quaternion algebra


def qmul(a, b):
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def qinv(q):
    """Inverse of a unit quaternion (its conjugate)."""
    r = np.array(q, dtype=float, copy=True)
    r[..., 1:] *= -1.0
    return r


def qnormalize(q):
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def qlog(q):
    """Rotation vector (axis * full angle, angle in [0, pi]); q is first
    taken with w >= 0."""
    q = np.asarray(q, dtype=float)
    sgn = np.where(q[..., 0] < 0, -1.0, 1.0)
    w = q[..., 0] * sgn
    v = q[..., 1:] * sgn[..., None]
    s = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(s, w)
    small = s < 1e-300
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(small, 2.0, angle / np.where(small, 1.0, s))
    return v * scale[..., None]


def qexp(v):
    """Exp(v) = (cos(|v|/2), sin(|v|/2) v/|v|)."""
    v = np.asarray(v, dtype=float)
    th = np.linalg.norm(v, axis=-1)
    small = th < 1e-8
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(small, 0.5 - th * th / 48.0,
                     np.sin(th / 2) / np.where(small, 1.0, th))
    return np.concatenate([np.cos(th / 2)[..., None], v * k[..., None]], axis=-1)


def geodesic(a, b):
    """d(a, b): the angle of a^-1 b in [0, pi] (accurate for small and large
    angles in double: 2 atan2(|vec|, |w|))."""
    r = qmul(qinv(a), b)
    return 2.0 * np.arctan2(np.linalg.norm(r[..., 1:], axis=-1), np.abs(r[..., 0]))


def make_continuous(q):
    q = np.array(q, dtype=float, copy=True)
    if q.shape[0] < 2:
        return q
    dots = np.einsum("tjc,tjc->tj", q[1:], q[:-1])
    flips = np.concatenate([np.zeros((1,) + dots.shape[1:], dtype=int),
                            (dots < 0).astype(int)], axis=0)
    sign = np.where(np.cumsum(flips, axis=0) % 2 == 1, -1.0, 1.0)
    return q * sign[..., None]


# ----------------------------------------------------------------------------
# boundary extension

BOUNDARIES = ("mirror", "hold", "extrapolate")


def mirror_index(t, F):
    """q[-t] for t < 0, q[2(F-1) - t] for t > F-1, periodic with period
    2(F-1) for clips shorter than the reach."""
    t = np.asarray(t)
    if F == 1:
        return np.zeros_like(t)
    per = 2 * (F - 1)
    m = np.mod(t, per)
    return np.where(m > F - 1, per - m, m)


def extend_rot(q, lo, hi, mode):
    """Samples t = lo .. hi (inclusive, may exceed [0, F)) of the rotation
    sequence q (F, J, 4), boundary-extended. Returns (hi-lo+1, J, 4)."""
    F = q.shape[0]
    t = np.arange(lo, hi + 1)
    if mode == "mirror":
        return q[mirror_index(t, F)]
    if mode == "hold":
        return q[np.clip(t, 0, F - 1)]
    if mode == "extrapolate":
        out = q[np.clip(t, 0, F - 1)].copy()
        if F < 2:
            return out
        left = t < 0
        if np.any(left):
            v0 = qlog(qmul(qinv(q[0]), q[1]))                    # (J, 3)
            tt = t[left].astype(float)[:, None, None]
            out[left] = qmul(np.broadcast_to(q[0], (left.sum(),) + q[0].shape),
                             qexp(tt * v0[None]))
        right = t > F - 1
        if np.any(right):
            v1 = qlog(qmul(qinv(q[F - 2]), q[F - 1]))
            tt = (t[right] - (F - 1)).astype(float)[:, None, None]
            out[right] = qmul(np.broadcast_to(q[F - 1], (right.sum(),) + q[0].shape),
                              qexp(tt * v1[None]))
        return out
    raise ValueError("unknown boundary mode %r" % mode)


def extend_pos(p, lo, hi, mode):
    """Euclidean analogue of extend_rot for translations p (F, J, 3)."""
    F = p.shape[0]
    t = np.arange(lo, hi + 1)
    if mode == "mirror":
        return p[mirror_index(t, F)]
    if mode == "hold":
        return p[np.clip(t, 0, F - 1)]
    if mode == "extrapolate":
        out = p[np.clip(t, 0, F - 1)].copy()
        if F < 2:
            return out
        left = t < 0
        if np.any(left):
            out[left] = p[0][None] + t[left].astype(float)[:, None, None] * (p[1] - p[0])[None]
        right = t > F - 1
        if np.any(right):
            out[right] = p[F - 1][None] + (t[right] - (F - 1)).astype(float)[:, None, None] \
                * (p[F - 1] - p[F - 2])[None]
        return out
    raise ValueError("unknown boundary mode %r" % mode)


# ----------------------------------------------------------------------------
# Lee-Shin construction


def lee_shin_b(masks):
    """masks (2k+1, ...) indexed r + k. Returns b (2k, ...) indexed r + k,
    r in [-k, k-1]:  b_r = -sum_{j=-k}^{r} m_j (r < 0),
                     b_r = +sum_{j=r+1}^{k} m_j (r >= 0)."""
    n = masks.shape[0]
    k = (n - 1) // 2
    left = -np.cumsum(masks, axis=0)                       # index r+k -> -sum_{-k..r}
    right = np.cumsum(masks[::-1], axis=0)[::-1]           # index i -> sum_{i..2k} (= j >= i-k)
    b = np.empty((2 * k,) + masks.shape[1:])
    if k > 0:
        b[:k] = left[:k]                                   # r = -k .. -1
        b[k:] = right[k + 1:]                              # r = 0 .. k-1 : sum_{j=r+1}^{k}
    return b


def lee_shin_apply(q, masks, mode):
    """H(q_i) = q_i Exp(sum_{r=-k}^{k-1} b_r w_{i+r}) with w_i = Log(q_i^-1 q_{i+1}).

    q (F, J, 4); masks either (2k+1,) (one mask for all samples) or
    (2k+1, F, J) (per-sample masks, e.g. bof)."""
    F = q.shape[0]
    if F == 1:
        return q.copy()
    masks = np.asarray(masks, dtype=float)
    k = (masks.shape[0] - 1) // 2
    if k == 0:
        return q.copy()
    qe = extend_rot(q, -k, F - 1 + k, mode)                # index t + k
    w = qlog(qmul(qinv(qe[:-1]), qe[1:]))                  # w_e[i + k] = w_i, i in [-k, F+k-2]
    b = lee_shin_b(masks)
    acc = np.zeros(q.shape[:-1] + (3,))
    for ri in range(2 * k):                                 # r = ri - k
        br = b[ri]
        if br.ndim == 0:
            acc += br * w[ri:ri + F]
        else:
            acc += br[..., None] * w[ri:ri + F]
    return qmul(q, qexp(acc))


def correlate_pos(p, mask, mode):
    """Euclidean counterpart: p'_i = sum_r m_r p_{i+r} (boundary-extended)."""
    F = p.shape[0]
    if F == 1:
        return p.copy()
    mask = np.asarray(mask, dtype=float)
    k = (mask.shape[0] - 1) // 2
    pe = extend_pos(p, -k, F - 1 + k, mode)
    out = np.zeros_like(p)
    for ri in range(2 * k + 1):
        m = mask[ri]
        if m.ndim == 0:
            out += m * pe[ri:ri + F]
        else:
            out += m[..., None] * pe[ri:ri + F]
    return out


# ----------------------------------------------------------------------------
# masks of the linear filters


def gaussian_mask(sigma_t, k=0):
    if not k:
        k = int(math.ceil(3.0 * sigma_t))
    r = np.arange(-k, k + 1, dtype=float)
    m = np.exp(-r * r / (2.0 * sigma_t * sigma_t))
    return m / m.sum()


MOVING_MEAN_MASK = np.array([2.0, 3.0, 2.0, 3.0, 2.0]) / 12.0


def butter_ba(n, wn):
    """Digital Butterworth low-pass, as scipy.signal.butter(n, wn) (output 'ba'):
    analog prototype poles, pre-warped lp2lp, bilinear transform at fs = 2."""
    m = np.arange(-n + 1, n, 2)
    p = -np.exp(1j * np.pi * m / (2.0 * n))                # buttap: no zeros, k = 1
    k = 1.0
    fs = 2.0
    warped = 2.0 * fs * math.tan(math.pi * wn / fs)
    p = warped * p                                          # lp2lp_zpk
    k = k * warped ** n
    fs2 = 2.0 * fs                                          # bilinear_zpk
    pz = (fs2 + p) / (fs2 - p)
    zz = -np.ones(n)
    kz = k * np.real(1.0 / np.prod(fs2 - p))
    b = np.real(kz * np.poly(zz))
    a = np.real(np.poly(pz))
    return b, a


def impulse_response(b, a, length):
    """Causal impulse response of b/a (direct-form recursion, like lfilter)."""
    b = np.asarray(b, float) / a[0]
    a = np.asarray(a, float) / a[0]
    h = np.zeros(length)
    nb, na = len(b), len(a)
    for n_ in range(length):
        acc = b[n_] if n_ < nb else 0.0
        for i in range(1, min(na, n_ + 1)):
            acc -= a[i] * h[n_ - i]
        h[n_] = acc
    return h


def butterworth_mask(order, cutoff_hz, frame_time, rel=1e-6, return_raw=False):
    fs = 1.0 / frame_time
    nyq = fs / 2.0
    if not cutoff_hz < 0.95 * nyq:
        raise ValueError("butterworth cutoff %g Hz must lie below 0.95 x Nyquist "
                         "(%g Hz) of the clip's frame rate %g fps" % (cutoff_hz, nyq, fs))
    b, a = butter_ba(order, cutoff_hz / nyq)
    # causal response long enough that its tail is negligible in double
    length = 256
    while True:
        h = impulse_response(b, a, length)
        peak = np.max(np.abs(h))
        if np.max(np.abs(h[-length // 8:])) < 1e-20 * peak or length > (1 << 20):
            break
        length *= 2
    # zero-phase (forward-backward) impulse response = autocorrelation of h,
    # g[n] = sum_m h[m] h[m+n] (direct sum)
    L = len(h)
    g = np.correlate(h, h, mode="full")[L - 1:]
    peak = g[0]
    assert peak >= np.max(np.abs(g))
    k = int(np.nonzero(np.abs(g) >= rel * peak)[0].max())
    mask = np.concatenate([g[1:k + 1][::-1], g[:k + 1]])
    if return_raw:
        return mask / mask.sum(), g
    return mask / mask.sum()


# ----------------------------------------------------------------------------
# linear filters


def linear_filter(q, p, mask, mode, passes=1, translations=True):
    q2, p2 = q, p
    for _ in range(passes):
        q2 = lee_shin_apply(q2, mask, mode)
        if translations and p2 is not None:
            p2 = correlate_pos(p2, mask, mode)
    return q2, p2


def gaussian_filter(q, p, sigma_t=1.0, k=0, boundary="mirror", translations=True):
    return linear_filter(q, p, gaussian_mask(sigma_t, k), boundary, 1, translations)


def butterworth_filter(q, p, frame_time, order=2, cutoff=6.0, boundary="mirror",
                       translations=True):
    return linear_filter(q, p, butterworth_mask(order, cutoff, frame_time), boundary, 1,
                         translations)


def moving_mean_filter(q, p, passes=5, boundary="mirror", translations=True):
    return linear_filter(q, p, MOVING_MEAN_MASK, boundary, passes, translations)


# ----------------------------------------------------------------------------
# bilateral orientation filter (Courty 2008, as fixed by the spec)


def bof_masks(q, sigma_t, sigma_g, k, mode, kernel="gaussian"):
    F = q.shape[0]
    qe = extend_rot(q, -k, F - 1 + k, mode)
    r = np.arange(-k, k + 1, dtype=float)
    m = np.empty((2 * k + 1,) + q.shape[:-1])
    for ri in range(2 * k + 1):
        d = geodesic(q, qe[ri:ri + F])                       # d(q_i, q_{i+r})
        if kernel == "gaussian":
            m[ri] = math.exp(-r[ri] ** 2 / (2 * sigma_t ** 2)) * np.exp(-d * d / (2 * sigma_g ** 2))
        elif kernel == "paper":
            d_half = d / 2.0
            sg = sigma_g / 2.0
            m[ri] = math.exp(-abs(r[ri]) / (2 * sigma_t ** 2)) * np.exp(-d_half / (2 * sg * sg))
        else:
            raise ValueError(kernel)
    return m / m.sum(axis=0, keepdims=True)


def bof_pos_masks(p, sigma_t, sigma_p, k, mode, kernel="gaussian"):
    """Euclidean bilateral weights for translations (sigma_p None = Gaussian).
    Temporal factor exp(-r^2/(2 sigma_t^2)) as written in the spec's
    Translations section (also for kernel=paper unless told otherwise)."""
    F = p.shape[0]
    pe = extend_pos(p, -k, F - 1 + k, mode)
    m = np.empty((2 * k + 1,) + p.shape[:-1])
    for ri in range(2 * k + 1):
        r = ri - k
        if kernel == "paper":
            wt = math.exp(-abs(r) / (2 * sigma_t ** 2))
        else:
            wt = math.exp(-r * r / (2 * sigma_t ** 2))
        if sigma_p:
            dd = np.sum((pe[ri:ri + F] - p) ** 2, axis=-1)
            m[ri] = wt * np.exp(-dd / (2 * sigma_p ** 2))
        else:
            m[ri] = wt
    return m / m.sum(axis=0, keepdims=True)


def bof(q, p, sigma_t=1.0, sigma_g=0.2, k=0, iterations=5, boundary="mirror",
        kernel="gaussian", sigma_p=None, translations=True, pos_kernel="gaussian"):
    if not k:
        k = int(math.ceil(3.0 * sigma_t))
    q2, p2 = q, p
    if q.shape[0] == 1:
        return q.copy(), (None if p is None else p.copy())
    for _ in range(iterations):
        q2 = lee_shin_apply(q2, bof_masks(q2, sigma_t, sigma_g, k, boundary, kernel), boundary)
        if translations and p2 is not None:
            p2 = correlate_pos(p2, bof_pos_masks(p2, sigma_t, sigma_p, k, boundary, pos_kernel),
                               boundary)
    return q2, p2


# ----------------------------------------------------------------------------
# non-local pose means (Dean & Lewis 2017, as fixed by the spec)


def nlpm_weights(q, K, P, h, boundary="mirror", space="tangent", dist_joints=None):
    """Returns (deltas, f) with f (F, 2K+1): f[t, delta+K] = f(t, t+delta),
    0 where t+delta is outside [0, F). Direct double sum over patch offsets
    and joints (no running sums)."""
    F, J = q.shape[:2]
    jd = np.arange(J) if dist_joints is None else np.asarray(dist_joints)
    qe = extend_rot(q, -P, F - 1 + P, boundary)[:, jd]       # index u + P, u in [-P, F-1+P]
    if space == "log":
        Le = qlog(qe)
    E = np.full((2 * K + 1, F + 2 * P), np.nan)              # E[delta+K, u+P] = e(u, u+delta)
    n = F + 2 * P
    for di, delta in enumerate(range(-K, K + 1)):
        lo = max(0, -delta)
        hi = min(n, n - delta)                               # u+P in [lo, hi)
        if hi <= lo:
            continue
        if space == "tangent":
            d = geodesic(qe[lo:hi], qe[lo + delta:hi + delta])
            E[di, lo:hi] = np.sum(d * d, axis=-1) / len(jd)
        else:
            diff = Le[lo:hi] - Le[lo + delta:hi + delta]
            E[di, lo:hi] = np.sum(np.sum(diff * diff, axis=-1), axis=-1) / len(jd)
    t = np.arange(F)
    D = np.full((F, 2 * K + 1), np.inf)
    for di, delta in enumerate(range(-K, K + 1)):
        s = t + delta
        valid = (s >= 0) & (s < F)
        acc = np.zeros(F)
        for o in range(-P, P + 1):
            idx = np.clip(t + o + P, 0, n - 1)
            acc = acc + np.where(valid, E[di, idx], 0.0)
        D[:, di] = np.where(valid, acc / (2 * P + 1), np.inf)
    D_other = D.copy()
    D_other[:, K] = np.inf
    Dmin = D_other.min(axis=1)
    f = np.zeros((F, 2 * K + 1))
    with np.errstate(invalid="ignore", over="ignore"):
        fo = np.exp(-(D_other - Dmin[:, None]) / (2.0 * h * h))
    fo[~np.isfinite(D_other)] = 0.0
    f[:] = fo
    f[:, K] = fo.max(axis=1)                                # self-weight rule
    return f


def gaussian_pos(p, sigma_t, boundary):
    """nlpm's translations (docs/positions.md, "Translations"; the spec's first pose-weighted mean of p[s] is
    withdrawn): p'[t] = sum_r exp(-r^2 / (2 s^2)) p[t+r] / sum_r exp(-r^2 / (2 s^2)),
    r in [-ceil(3 s), ceil(3 s)], boundary-extended; s = 0 leaves p as it is."""
    if sigma_t <= 0 or p.shape[0] < 2:
        return p.copy()
    k = int(math.ceil(3 * sigma_t))
    r = np.arange(-k, k + 1, dtype=float)
    m = np.exp(-r * r / (2 * sigma_t * sigma_t))
    return correlate_pos(p, m / m.sum(), boundary)


def translation_noise(p, frame_time):
    """(sigma, accel) of the translations (docs/positions.md, "Translations", automatic width): sigma = max
    over joints of 1.4826 MAD of the third-difference components / sqrt(20); accel = that joint's
    RMS second-difference component after a Gaussian of 0.1 s (mirror), away from the ends."""
    F, J = p.shape[:2]
    if F < 4:
        return 0.0, 0.0
    best, accel = 0.0, 0.0
    s = 0.1 / frame_time
    k = int(math.ceil(3 * s))
    r = np.arange(-k, k + 1, dtype=float)
    m = np.exp(-0.5 * r * r / (s * s))
    for j in range(J):
        x = p[:, j].astype(float)
        c = (x[3:] - 3 * x[2:-1] + 3 * x[1:-2] - x[:-3]).reshape(-1)
        sigma = 1.4826 * np.median(np.abs(c - np.median(c))) / math.sqrt(20.0)
        if not (sigma > best) and best > 0:
            continue
        ext = x[mirror_index(np.arange(-k, F + k), F)]
        smooth = sum(m[i] * ext[i:i + F] for i in range(2 * k + 1)) / m.sum()
        a = smooth[2:] - 2 * smooth[1:-1] + smooth[:-2]     # centred at t = 1 .. F-2
        t = np.arange(1, F - 1)
        keep = (t >= max(1, k)) & (t + 1 < F - k)
        best = sigma
        accel = float(np.sqrt(np.mean(a[keep] ** 2))) if np.any(keep) else -1.0
    return float(best), accel


def rest_height(m):
    """The skeleton's vertical extent in its rest pose (offsets only, End Sites included)."""
    pos = []
    ys = []
    for j, pa in enumerate(m.parents):
        here = np.zeros(3) if pa < 0 else pos[pa] + np.asarray(m.offsets[j], dtype=float)
        pos.append(here)
        ys.append(here[1])
        for e in m.end_sites[j]:
            ys.append((here + np.asarray(e, dtype=float))[1])
    return float(max(ys) - min(ys)) if ys else 0.0


def automatic_translation_sigma_t(p, frame_time, body_height):
    """docs/positions.md, "Translations": 0 unless the positions are noisy (sigma > 0.0015 body heights) and
    the clip is long enough to measure accel; else 1.3 (sigma^2 / (2 sqrt(pi) accel^2))^(1/5)
    frames, at most 0.2 s."""
    sigma, accel = translation_noise(p, frame_time)
    if not (body_height > 0 and sigma > 0.0015 * body_height) or accel < 0:
        return 0.0
    cap = 0.2 / frame_time
    if accel == 0:
        return cap
    return min(1.3 * (sigma * sigma / (2 * math.sqrt(math.pi) * accel * accel)) ** 0.2, cap)


def nlpm(q, p, K=10, P=5, h=0.03, boundary="mirror", space="tangent", translations=True,
         translation_sigma_t=1.0):
    F, J = q.shape[:2]
    if F == 1:
        return q.copy(), (None if p is None else p.copy())
    f = nlpm_weights(q, K, P, h, boundary, space)
    tot = f.sum(axis=1)
    t = np.arange(F)
    acc = np.zeros((F, J, 3))
    L = qlog(q) if space == "log" else None
    for di, delta in enumerate(range(-K, K + 1)):
        s = t + delta
        valid = (s >= 0) & (s < F)
        sc = np.clip(s, 0, F - 1)
        w = np.where(valid, f[:, di], 0.0)
        if space == "tangent":
            acc += w[:, None, None] * qlog(qmul(qinv(q), q[sc]))
        else:
            acc += w[:, None, None] * L[sc]
    mean = acc / tot[:, None, None]
    if space == "tangent":
        q2 = qmul(q, qexp(mean))
    else:
        q2 = qexp(mean)
    p2 = p
    if translations and p is not None:
        p2 = gaussian_pos(p, translation_sigma_t, boundary)
    return q2, p2


# ----------------------------------------------------------------------------
# noise estimate and metrics


def noise_estimate(q):
    """sigma_hat: median over moving joints of 1.4826 MAD(c) / sqrt(6), c the
    components of the second differences of the local displacements. Returns
    None when no joint moves (or the clip is too short)."""
    F = q.shape[0]
    if F < 3:
        return None
    w = qlog(qmul(qinv(q[:-1]), q[1:]))                      # (F-1, J, 3)
    step = np.linalg.norm(w, axis=-1)
    moving = np.median(step, axis=0) > 1e-5
    if not np.any(moving):
        return None
    c = (w[1:] - w[:-1])[:, moving]                          # (F-2, Jm, 3)
    c = np.transpose(c, (1, 0, 2)).reshape(c.shape[1], -1)
    med = np.median(c, axis=1, keepdims=True)
    mad = np.median(np.abs(c - med), axis=1)
    return float(np.median(1.4826 * mad / math.sqrt(6.0)))


def rmse(r, g):
    d = geodesic(r, g)
    return float(math.sqrt(np.mean(d * d)))


def psnr(r, g):
    e = rmse(r, g)
    if e == 0:
        return float("inf")
    return 10.0 * math.log10(math.pi ** 2 / (e * e))


def angular_speed(q, frame_time):
    return np.linalg.norm(qlog(qmul(qinv(q[:-1]), q[1:])), axis=-1) / frame_time


def add_gaussian_noise(q, sigma, rng):
    n = rng.normal(0.0, sigma, size=q.shape[:-1] + (3,))
    return qmul(q, qexp(n))


# ----------------------------------------------------------------------------
# self-checks of the oracle itself


def _selftest():
    rng = np.random.default_rng(7)
    F = 60
    # 1. single axis: Lee-Shin == correlation of the angle (steps below pi)
    theta = np.cumsum(rng.normal(0, 0.4, F)) + np.linspace(0, 6, F)
    axis = np.array([0.3, -0.5, 0.8]); axis /= np.linalg.norm(axis)
    q = qexp(theta[:, None, None] * axis[None, None, :])     # (F, 1, 4)
    q = make_continuous(q)
    for mode in BOUNDARIES:
        for mask in (gaussian_mask(1.7), MOVING_MEAN_MASK, butterworth_mask(2, 6, 1 / 120.),
                     np.array([0.1, 0.5, 0.15, 0.05, 0.2])):       # asymmetric
            k = (len(mask) - 1) // 2
            out = lee_shin_apply(q, mask, mode)
            th_out = np.einsum("tc,c->t", qlog(out)[:, 0], axis)
            # scalar correlation of the extended angle signal
            if mode == "mirror":
                te = theta[mirror_index(np.arange(-k, F + k), F)]
            elif mode == "hold":
                te = theta[np.clip(np.arange(-k, F + k), 0, F - 1)]
            else:
                t = np.arange(-k, F + k)
                te = np.where(t < 0, theta[0] + t * (theta[1] - theta[0]),
                              np.where(t > F - 1, theta[-1] + (t - F + 1) * (theta[-1] - theta[-2]),
                                       theta[np.clip(t, 0, F - 1)]))
            ref = np.array([np.dot(mask, te[i:i + 2 * k + 1]) for i in range(F)])
            # compare as rotations (angles mod 2 pi)
            dq = geodesic(out[:, 0], qexp(ref[:, None] * axis))
            assert dq.max() < 1e-12, (mode, dq.max())
            # and the Euclidean counterpart is the same correlation
            pp = correlate_pos(theta[:, None, None] * np.ones((1, 1, 3)), mask, mode)[:, 0, 0]
            assert np.allclose(pp, ref, atol=1e-12)
    # 2. bof single axis == scalar bilateral filter of the angle
    theta = np.cumsum(rng.normal(0, 0.05, F)); theta[30:] += 1.0
    q = qexp(theta[:, None, None] * axis[None, None, :])
    qb, _ = bof(q, None, sigma_t=1.5, sigma_g=0.2, iterations=1, boundary="mirror")
    k = 5
    te = theta[mirror_index(np.arange(-k, F + k), F)]
    ref = np.empty(F)
    for i in range(F):
        win = te[i:i + 2 * k + 1]
        r = np.arange(-k, k + 1)
        m = np.exp(-r ** 2 / (2 * 1.5 ** 2)) * np.exp(-(win - theta[i]) ** 2 / (2 * 0.2 ** 2))
        ref[i] = np.dot(m, win) / m.sum()
    assert geodesic(qb[:, 0], qexp(ref[:, None] * axis)).max() < 1e-12
    # 3. coordinate invariance of bof
    q3 = make_continuous(qexp(rng.normal(0, 0.3, (F, 2, 3)) + np.linspace(0, 2, F)[:, None, None]))
    a = qexp(np.array([0.3, 1.0, -0.4])); b_ = qexp(np.array([-1.2, 0.2, 0.5]))
    lhs, _ = bof(qmul(qmul(a, q3), b_), None)
    rhs = qmul(qmul(a, bof(q3, None)[0]), b_)
    assert geodesic(lhs, rhs).max() < 1e-10
    # 4. bof -> Lee-Shin gaussian as sigma_g -> inf
    g1, _ = bof(q3, None, sigma_g=1e6, iterations=1)
    g2, _ = gaussian_filter(q3, None, 1.0)
    assert geodesic(g1, g2).max() < 1e-10
    # 5. butterworth design against known scipy values (scipy.signal.butter(2, 0.1))
    b, a_ = butter_ba(2, 0.1)
    assert np.allclose(b, [0.02008337, 0.04016673, 0.02008337], atol=1e-8), b
    assert np.allclose(a_, [1.0, -1.56101808, 0.64135154], atol=1e-8), a_
    b4, a4 = butter_ba(4, 0.25)
    # scipy.signal.butter(4, 0.25): b = [0.01020948, 0.04083792, 0.06125688, 0.04083792, 0.01020948]
    assert np.allclose(b4, [0.01020948, 0.04083792, 0.06125688, 0.04083792, 0.01020948], atol=1e-8)
    assert np.allclose(a4, [1., -1.96842779, 1.73586071, -0.72447083, 0.1203896], atol=1e-8)
    # DC gain of the zero-phase response = (sum b / sum a)^2 = 1
    _, g = butterworth_mask(2, 6, 1 / 120., return_raw=True)
    assert abs(g[0] + 2 * g[1:].sum() - 1) < 1e-9
    # 6. nlpm: identical poses -> unchanged; extreme h -> plain window mean
    qs = np.repeat(q3[:1], F, axis=0)
    assert geodesic(nlpm(qs, None, h=0.1)[0], qs).max() < 1e-12
    # 7. nlpm weights: vectorised direct sum == naive per-(t, s, o, j) loops
    qn = make_continuous(qexp(rng.normal(0, 0.2, (9, 2, 3))))
    for mode in BOUNDARIES:
        for space in ("tangent", "log"):
            K, P, h = 3, 2, 0.15
            f = nlpm_weights(qn, K, P, h, mode, space)
            Fn = qn.shape[0]
            for t in range(Fn):
                Ds = {}
                for s in range(max(0, t - K), min(Fn, t + K + 1)):
                    acc = 0.0
                    for o in range(-P, P + 1):
                        a = extend_rot(qn, t + o, t + o, mode)[0]
                        b = extend_rot(qn, s + o, s + o, mode)[0]
                        for j in range(qn.shape[1]):
                            if space == "tangent":
                                acc += float(geodesic(a[j], b[j])) ** 2 / qn.shape[1]
                            else:
                                acc += float(np.sum((qlog(a[j]) - qlog(b[j])) ** 2)) / qn.shape[1]
                    Ds[s] = acc / (2 * P + 1)
                others = [s for s in Ds if s != t]
                dmin = min(Ds[s] for s in others)
                for s in others:
                    assert abs(f[t, s - t + K] - math.exp(-(Ds[s] - dmin) / (2 * h * h))) < 1e-12
                assert f[t, K] == max(f[t, s - t + K] for s in others)
    # 8. nlpm with h -> infinity is the plain tangent-space mean over the window
    q8, _ = nlpm(q3, None, K=2, P=1, h=1e6)
    for t in (0, 10, F - 1):
        ss = range(max(0, t - 2), min(F, t + 3))
        mean = sum(qlog(qmul(qinv(q3[t]), q3[s])) for s in ss) / len(ss)
        assert geodesic(q8[t], qmul(q3[t], qexp(mean))).max() < 1e-9
    print("spec_filters self-test ok")


if __name__ == "__main__":
    _selftest()
