#!/usr/bin/python3
"""Check `mocap-clean clean` against the clean-room spec oracle.

    python3 check_cli.py --binary PATH --data DIR [--work TMPDIR] [--quick]

Builds noisy test clips from real CMU BVH files (every joint with its own
rotation order, all six orders used, and position channels on every joint),
runs the program on them for a list of method configurations (named methods,
no --pops: the spec's filter exactly by default), reads its BVH output and compares it with spec_filters.py run on
the same input (as read back by bvh.py from the noisy files).

Exit status: 0 all configurations within tolerance, 1 some failed (or the
oracle's own self-test failed), 77 data folder missing or no numpy (test
skipped), 2 usage / binary not found.
"""

import argparse
import contextlib
import io
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

try:
    import numpy as np
except ImportError:
    # e.g. a pyenv/venv python3 first on PATH: fall back to the system one
    # (Debian's python3-numpy), once
    if (os.path.realpath(sys.executable) != os.path.realpath("/usr/bin/python3")
            and os.access("/usr/bin/python3", os.X_OK)
            and not os.environ.get("SPEC_ORACLE_REEXEC")):
        os.environ["SPEC_ORACLE_REEXEC"] = "1"
        os.execv("/usr/bin/python3", ["/usr/bin/python3"] + sys.argv)
    print("SKIP: numpy is not available to %s (install python3-numpy); nothing checked"
          % sys.executable)
    sys.exit(77)

sys.dont_write_bytecode = True      # leave no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bvh  # noqa: E402
import spec_filters as sf  # noqa: E402

# tolerances (the contract)
ROT_RMS_TOL = 1e-5        # rad
ROT_MAX_TOL = 1e-4        # rad
# translations: per joint, max |error| <= TRANS_REL_TOL * scale_j, with
# scale_j = max(1, max over frames and axes of |p[t][j]|) in the file's length
# unit (see trans_scale()). The error floor of a float32 engine that prints
# ~8 digits is ~1e-7 of the magnitude (measured: <= 3.4e-7); 1e-5 leaves a
# 30x margin and still catches errors of ~1% of the added position noise on
# the root (scale ~30 units -> 3e-4 vs noise 0.02). The brief's example,
# 1e-4, would let a root error of 3e-3 pass (15% of the noise).
TRANS_REL_TOL = 1e-5
AMBIG_PI = 1e-6           # spec: steps within 1e-6 rad of pi are ambiguous

ROT_NOISE = 0.03          # rad, spec's gaussian noise model q := q Exp(n)
SEED = 20240611

# (source file, first frame, frame count) ; first frame 0 keeps CMU's
# synthetic T-pose frame (large steps of 80-180 degrees).
CLIPS_FULL = [
    ("cmu_mb_02_01.bvh", 0, 344),
    ("cmu_mb_05_02.bvh", 400, 500),
    ("cmu_mb_06_14.bvh", 1, 450),
    ("cmu_mb_02_03.bvh", 60, 7),     # short: mirror repeats periodically
    ("cmu_mb_02_03.bvh", 90, 2),
    ("cmu_mb_02_03.bvh", 120, 1),    # 1 frame: returned unchanged
]
CLIPS_QUICK = [
    ("cmu_mb_02_01.bvh", 0, 200),
    ("cmu_mb_06_14.bvh", 1, 200),
    ("cmu_mb_02_03.bvh", 60, 7),
]

# name, CLI args, oracle callable(q, p, frame_time) -> (q', p'), reach(F)->frames
def automatic(q, p, run):
    """`run(sigma_hat)`, or the clip unchanged when it has no noise estimate (spec: a clip where
    no joint moves, or too short for second differences, has nothing to filter)."""
    s = sf.noise_estimate(q)
    return run(s) if s else (q.copy(), p.copy())


BODY_HEIGHT = [0.0]  # the current clip's, for the automatic translation width

CONFIGS = [
    ("bof defaults",
     ["--method", "bof", "--sigma-t", "1", "--sigma-g", "0.2", "--iterations", "5",
      "--kernel", "gaussian", "--boundary", "mirror"],
     lambda q, p, ft: sf.bof(q, p, 1.0, 0.2, 0, 5, "mirror", "gaussian")),
    ("bof --kernel paper",
     ["--method", "bof", "--kernel", "paper", "--sigma-t", "1", "--sigma-g", "0.2",
      "--iterations", "5"],
     lambda q, p, ft: sf.bof(q, p, 1.0, 0.2, 0, 5, "mirror", "paper")),
    ("bof --sigma-p 0.1 hold",
     ["--method", "bof", "--sigma-p", "0.1", "--boundary", "hold"],
     lambda q, p, ft: sf.bof(q, p, 1.0, 0.2, 0, 5, "hold", "gaussian", sigma_p=0.1)),
    ("bof --iterations 1 --sigma-t 2",
     ["--method", "bof", "--iterations", "1", "--sigma-t", "2"],
     lambda q, p, ft: sf.bof(q, p, 2.0, 0.2, 0, 1, "mirror", "gaussian")),
    ("bof -k 2 sigma-g 0.5 extrapolate",
     ["--method", "bof", "--window", "2", "--sigma-g", "0.5", "--iterations", "3",
      "--boundary", "extrapolate"],
     lambda q, p, ft: sf.bof(q, p, 1.0, 0.5, 2, 3, "extrapolate", "gaussian")),
    ("nlpm h 0.03 tangent",
     ["--method", "nlpm", "-K", "10", "-P", "5", "--h", "0.03", "--space", "tangent",
      "--translation-sigma-t", "2"],
     lambda q, p, ft: sf.nlpm(q, p, 10, 5, 0.03, "mirror", "tangent", translation_sigma_t=2)),
    ("nlpm h 0.03 --space log",
     ["--method", "nlpm", "--h", "0.03", "--space", "log", "--translation-sigma-t", "1"],
     lambda q, p, ft: sf.nlpm(q, p, 10, 5, 0.03, "mirror", "log", translation_sigma_t=1)),
    ("nlpm K3 P2 h 0.05 extrapolate",
     ["--method", "nlpm", "-K", "3", "-P", "2", "--h", "0.05", "--boundary", "extrapolate",
      "--translation-sigma-t", "3.5"],
     lambda q, p, ft: sf.nlpm(q, p, 3, 2, 0.05, "extrapolate", "tangent",
                              translation_sigma_t=3.5)),
    ("nlpm K6 P0 h 0.02 hold",
     ["--method", "nlpm", "-K", "6", "-P", "0", "--h", "0.02", "--boundary", "hold",
      "--translation-sigma-t", "0"],
     lambda q, p, ft: sf.nlpm(q, p, 6, 0, 0.02, "hold", "tangent", translation_sigma_t=0)),
    ("gaussian sigma 1",
     ["--method", "gaussian", "--sigma-t", "1"],
     lambda q, p, ft: sf.gaussian_filter(q, p, 1.0, 0, "mirror")),
    ("gaussian sigma 2.5 extrapolate",
     ["--method", "gaussian", "--sigma-t", "2.5", "--boundary", "extrapolate"],
     lambda q, p, ft: sf.gaussian_filter(q, p, 2.5, 0, "extrapolate")),
    ("gaussian sigma 1.5 k 2 hold",
     ["--method", "gaussian", "--sigma-t", "1.5", "--window", "2", "--boundary", "hold"],
     lambda q, p, ft: sf.gaussian_filter(q, p, 1.5, 2, "hold")),
    ("butterworth defaults",
     ["--method", "butterworth", "--order", "2", "--cutoff", "6"],
     lambda q, p, ft: sf.butterworth_filter(q, p, ft, 2, 6.0, "mirror")),
    ("butterworth 4 / 10 Hz",
     ["--method", "butterworth", "--order", "4", "--cutoff", "10"],
     lambda q, p, ft: sf.butterworth_filter(q, p, ft, 4, 10.0, "mirror")),
    ("butterworth 3 / 4 Hz extrapolate",
     ["--method", "butterworth", "--order", "3", "--cutoff", "4", "--boundary", "extrapolate"],
     lambda q, p, ft: sf.butterworth_filter(q, p, ft, 3, 4.0, "extrapolate")),
    ("moving-mean defaults",
     ["--method", "moving-mean", "--passes", "5"],
     lambda q, p, ft: sf.moving_mean_filter(q, p, 5, "mirror")),
    ("moving-mean 2 passes hold",
     ["--method", "moving-mean", "--passes", "2", "--boundary", "hold"],
     lambda q, p, ft: sf.moving_mean_filter(q, p, 2, "hold")),
    ("bof --translations keep",
     ["--method", "bof", "--translations", "keep"],
     lambda q, p, ft: sf.bof(q, p, 1.0, 0.2, 0, 5, "mirror", "gaussian", translations=False)),
    # Nothing but the method: every default of the spec.
    ("bof, no options",
     ["--method", "bof"],
     lambda q, p, ft: sf.bof(q, p, 1.0, 0.2, 0, 5, "mirror", "gaussian")),
    ("gaussian, no options",
     ["--method", "gaussian"],
     lambda q, p, ft: sf.gaussian_filter(q, p, 1.0, 0, "mirror")),
    ("butterworth, no options",
     ["--method", "butterworth"],
     lambda q, p, ft: sf.butterworth_filter(q, p, ft, 2, 6.0, "mirror")),
    ("moving-mean, no options",
     ["--method", "moving-mean"],
     lambda q, p, ft: sf.moving_mean_filter(q, p, 5, "mirror")),
    # Automatic parameters, by the rules docs/automatic-parameters.md documents:
    # nlpm h = 1.2 sigma_hat and the translations' Gaussian from their estimated noise; bof sigma_g = 3 sigma_hat, sigma_t = max(1, 10 sqrt(sigma_hat)),
    # with sigma_hat the spec's noise estimate of the clip.
    ("nlpm, no options (h = 1.2 sigma_hat)",
     ["--method", "nlpm"],
     lambda q, p, ft: automatic(q, p, lambda s: sf.nlpm(
         q, p, 10, 5, 1.2 * s,
         translation_sigma_t=sf.automatic_translation_sigma_t(p, ft, BODY_HEIGHT[0])))),
    ("bof automatic (sigma_g = 3 sigma_hat)",
     ["--method", "bof", "--sigma-g", "0", "--sigma-t", "0"],
     lambda q, p, ft: automatic(q, p, lambda s: sf.bof(q, p, max(1.0, 10 * math.sqrt(s)), 3 * s))),
    ("none (round trip)",
     ["--method", "none"],
     lambda q, p, ft: (q.copy(), p.copy())),
]
QUICK_CONFIGS = None  # all configs also in --quick (on fewer, shorter clips)


def reach_of(args, ft):
    """How many frames away an input step can influence an output sample
    (used only to exclude samples near spec-ambiguous steps)."""
    def val(opt, default):
        return float(args[args.index(opt) + 1]) if opt in args else default
    method = args[args.index("--method") + 1]
    if method == "bof":
        st = val("--sigma-t", 1.0)
        k = int(val("--window", 0)) or int(math.ceil(3 * st))
        return k * int(val("--iterations", 5))
    if method == "gaussian":
        st = val("--sigma-t", 1.0)
        return int(val("--window", 0)) or int(math.ceil(3 * st))
    if method == "butterworth":
        m = sf.butterworth_mask(int(val("--order", 2)), val("--cutoff", 6.0), ft)
        return (len(m) - 1) // 2
    if method == "moving-mean":
        return 2 * int(val("--passes", 5))
    if method == "nlpm":
        return 1          # Log(q_t^-1 q_s) of a frame-to-frame step enters at t and s
    return 0


# ----------------------------------------------------------------------------
# test clips


def build_clips(data, work, quick, log):
    rng = np.random.default_rng(SEED)
    clip_dir = os.path.join(work, "input")
    os.makedirs(clip_dir, exist_ok=True)
    clips = []
    for ci, (src, first, count) in enumerate(CLIPS_QUICK if quick else CLIPS_FULL):
        m = bvh.read_bvh(os.path.join(data, src))
        count = min(count, m.F - first)
        m.q = bvh.make_continuous(m.q[first:first + count])
        m.p = m.p[first:first + count]
        F, J = m.q.shape[:2]
        # rotation order per joint: every one of the six orders, shuffled
        orders = [bvh.ORDERS[i % 6] for i in range(J)]
        rng.shuffle(orders)
        # positions on every joint: root keeps its capture; the others get
        # OFFSET + a small smooth motion; all get a little noise
        t = np.arange(F) * m.frame_time
        for j in range(J):
            if m.has_pos[j]:
                base = m.p[:, j]
                noise = 0.02
            else:
                off = m.offsets[j]
                amp = (0.03 + 0.02 * np.linalg.norm(off)) * rng.uniform(0.5, 1.5, 3)
                freq = rng.uniform(0.3, 2.0, 3)
                ph = rng.uniform(0, 2 * np.pi, 3)
                base = off[None] + amp[None] * np.sin(2 * np.pi * freq[None] * t[:, None] + ph[None])
                noise = 0.005
            m.p[:, j] = base + rng.normal(0, noise, (F, 3))
        m.q = sf.add_gaussian_noise(m.q, ROT_NOISE, rng)
        bvh.set_layout(m, orders, np.ones(J, dtype=bool))
        name = "clip%d_%s_%d_%d.bvh" % (ci, src[len("cmu_mb_"):-4], first, count)
        path = os.path.join(clip_dir, name)
        bvh.write_bvh(m, path)
        back = bvh.read_bvh(path)     # the oracle's input is what the file says
        clips.append((name, path, back))
        used = sorted(set(orders))
        log("  %-28s %4d frames x %d joints, orders used: %s" % (name, F, J, " ".join(used)))
    return clip_dir, clips


def ambiguous_steps(q):
    """(F-1, J) bool: frame-to-frame steps within AMBIG_PI of pi."""
    if q.shape[0] < 2:
        return np.zeros((0, q.shape[1]), dtype=bool)
    d = sf.geodesic(q[:-1], q[1:])
    return np.abs(d - math.pi) < AMBIG_PI


def exclusion_mask(q, reach, boundary):
    F, J = q.shape[:2]
    amb = ambiguous_steps(q)
    ex = np.zeros((F, J), dtype=bool)
    for s, j in zip(*np.nonzero(amb)):
        if F <= 2 * reach + 2:
            ex[:, j] = True
        else:
            ex[max(0, s - reach):min(F, s + reach + 2), j] = True
    return ex


def trans_scale(p):
    """Per joint: the scale the translation error is measured against,
    max over axes of the largest |value| (float32 storage and printing error
    grow with it) -- at least 1 file unit."""
    return np.maximum(1.0, np.max(np.abs(p), axis=(0, 2)))


# ----------------------------------------------------------------------------


def run_config(binary, clip_dir, out_dir, args):
    if os.path.isdir(out_dir):
        shutil.rmtree(out_dir)
    # No --pops: a named method must be the spec's filter exactly by default.
    cmd = [binary, "clean", clip_dir, "-o", out_dir, "--no-progress", "--threads", "2"] + args
    t0 = time.time()
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return r, time.time() - t0, cmd


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--binary", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--work", default=None)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only", default=None, help="run only configs whose name contains this")
    ap.add_argument("--verbose", action="store_true")
    a = ap.parse_args()

    needed = [c[0] for c in (CLIPS_QUICK if a.quick else CLIPS_FULL)]
    if not os.path.isdir(a.data) or not all(os.path.isfile(os.path.join(a.data, n)) for n in needed):
        print("SKIP: data folder %r missing (or lacks %s); nothing checked"
              % (a.data, ", ".join(sorted(set(needed)))))
        return 77
    if not (os.path.isfile(a.binary) and os.access(a.binary, os.X_OK)):
        print("ERROR: binary %r not found or not executable" % a.binary)
        return 2

    t_start = time.time()
    # the oracle's own checks first (single-axis Lee-Shin == correlation of the
    # angle, bof reductions and invariance, butterworth design vs scipy values,
    # nlpm direct sum vs naive loops, Euler round trips of all six orders)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            bvh._selftest()
            sf._selftest()
    except AssertionError as e:
        print("FAIL: the oracle's own self-test failed: %r" % (e,))
        return 1
    work = a.work or tempfile.mkdtemp(prefix="spec_oracle_")
    os.makedirs(work, exist_ok=True)

    def log(s):
        print(s, flush=True)

    log("spec oracle check of %s" % a.binary)
    log("work folder: %s" % work)
    log("building test clips (seed %d, rotation noise %.3g rad):" % (SEED, ROT_NOISE))
    clip_dir, clips = build_clips(a.data, work, a.quick, log)
    for name, _, m in clips:
        if m.F >= 3:
            est = sf.noise_estimate(m.q)
            if est is not None:
                log("  %-28s spec noise estimate sigma_hat = %.4f rad (added %.3g)"
                    % (name, est, ROT_NOISE))

    rows = []
    failed = []
    t_prog = 0.0
    t_orac = 0.0
    for cname, args, oracle in CONFIGS:
        if a.only and a.only not in cname:
            continue
        out_dir = os.path.join(work, "out_" + "".join(c if c.isalnum() else "_" for c in cname))
        r, dt, cmd = run_config(a.binary, clip_dir, out_dir, args)
        t_prog += dt
        if r.returncode != 0:
            log("%s: program exit %d: %s" % (cname, r.returncode, (r.stderr or r.stdout).strip()))
        rot_sq = 0.0
        rot_n = 0
        rot_max = 0.0
        rot_where = ""
        tr_max = 0.0
        tr_rel = 0.0
        tr_where = ""
        effect = 0.0
        excluded = 0
        problems = []
        t0 = time.time()
        for name, path, m in clips:
            outp = os.path.join(out_dir, name)
            if not os.path.isfile(outp):
                problems.append("%s: no output" % name)
                continue
            try:
                o = bvh.read_bvh(outp)
            except Exception as e:  # noqa: BLE001
                problems.append("%s: unreadable output: %s" % (name, e))
                continue
            if o.names != m.names or o.F != m.F:
                problems.append("%s: output has %d joints x %d frames, input %d x %d"
                                % (name, o.J, o.F, m.J, m.F))
                continue
            if o.channels != m.channels:
                bad = [m.names[j] for j in range(m.J) if o.channels[j] != m.channels[j]]
                problems.append("%s: channel layout changed on %s" % (name, ", ".join(bad[:5])))
            BODY_HEIGHT[0] = sf.rest_height(m)
            qo, po = oracle(m.q, m.p.copy(), m.frame_time)
            d = sf.geodesic(o.q, qo)
            ft = m.frame_time
            boundary = args[args.index("--boundary") + 1] if "--boundary" in args else "mirror"
            ex = exclusion_mask(m.q, reach_of(args, ft), boundary)
            excluded += int(ex.sum())
            dk = np.where(ex, 0.0, d)
            rot_sq += float(np.sum(dk * dk))
            rot_n += int((~ex).sum())
            if dk.size and dk.max() > rot_max:
                t, j = np.unravel_index(np.argmax(dk), dk.shape)
                rot_max = float(dk.max())
                rot_where = "%s %s f%d" % (name.split("_")[0], m.names[j], t)
            effect = max(effect, float(np.sqrt(np.mean(sf.geodesic(qo, m.q) ** 2))))
            if a.verbose:
                log("    %-28s rot rms %.2e max %.2e" % (name, math.sqrt(np.mean(dk * dk)), dk.max()))
            hp = m.has_pos & o.has_pos
            if np.any(m.has_pos != o.has_pos):
                problems.append("%s: position channels differ" % name)
            if np.any(hp):
                e = np.abs(o.p[:, hp] - po[:, hp])                   # (F, Jp, 3)
                ej = e.max(axis=(0, 2))
                sc = trans_scale(m.p[:, hp])
                rel = ej / sc
                if e.max() > tr_max:
                    tr_max = float(e.max())
                if rel.max() > tr_rel:
                    jj = int(np.argmax(rel))
                    tr_rel = float(rel.max())
                    t = int(np.argmax(e[:, jj].max(axis=1)))
                    tr_where = "%s %s f%d" % (name.split("_")[0],
                                              np.array(m.names)[hp][jj], t)
        t_orac += time.time() - t0
        rms = math.sqrt(rot_sq / rot_n) if rot_n else float("nan")
        ok = (not problems and rot_n > 0 and rms <= ROT_RMS_TOL and rot_max <= ROT_MAX_TOL
              and tr_rel <= TRANS_REL_TOL)
        rows.append((cname, rms, rot_max, rot_where, tr_max, tr_rel, tr_where, excluded,
                     effect, ok))
        for pr in problems:
            log("%s: %s" % (cname, pr))
        if not ok:
            failed.append(cname)
        if a.verbose:
            log("%-34s rms %.2e max %.2e (%s) tr %.2e rel %.2e (%s)"
                % (cname, rms, rot_max, rot_where, tr_max, tr_rel, tr_where))

    log("")
    log("tolerances: rotation RMS <= %.0e rad and max <= %.0e rad (geodesic, per joint-frame);"
        % (ROT_RMS_TOL, ROT_MAX_TOL))
    log("            translation max |error| <= %.0e x scale_j per joint, scale_j = max(1, max_t,axis |p[t][j]|)"
        % TRANS_REL_TOL)
    log("            ('tr max' = largest absolute error, 'tr rel' = largest error / scale_j)")
    log("excluded: joint-frames within the filter's reach of an input step within %.0e rad of pi"
        % AMBIG_PI)
    log("effect: RMS geodesic change the oracle filter makes to the input (shows the test bites)")
    log("")
    hdr = "%-34s %10s %10s %10s %10s %6s %8s  %-4s  %s" % (
        "config", "rot RMS", "rot max", "tr max", "tr rel", "excl", "effect", "ok",
        "worst rotation / translation at")
    log(hdr)
    log("-" * len(hdr))
    for (cname, rms, rmax, rw, tmax, trel, tw, exc, eff, ok) in rows:
        log("%-34s %10.2e %10.2e %10.2e %10.2e %6d %8.4f  %-4s  %s / %s" % (
            cname, rms, rmax, tmax, trel, exc, eff, "ok" if ok else "FAIL", rw, tw))
    log("")
    log("runtime: %.1f s total (program %.1f s, oracle+compare %.1f s)"
        % (time.time() - t_start, t_prog, t_orac))
    if failed:
        log("FAILED: %d of %d configs: %s" % (len(failed), len(rows), "; ".join(failed)))
        log("inputs and program outputs kept in %s" % work)
        return 1
    log("all %d configs within tolerance" % len(rows))
    if not a.work:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
