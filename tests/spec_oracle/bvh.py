"""Minimal, independent BVH reader/writer for the spec oracle (double precision).

Written from the BVH format conventions only (no engine code consulted).

Conventions
-----------
* Angles in the file are degrees.
* The rotation channels of a joint are composed in the order they are listed:
  ``CHANNELS 3 Zrotation Yrotation Xrotation`` means ``R = Rz(a) * Ry(b) * Rx(c)``
  (intrinsic), i.e. the quaternion ``q = qz(a) * qy(b) * qx(c)``.
* Quaternions are Hamilton ``(w, x, y, z)``, numpy float64.
* Position channels of a joint are its local translation (they replace the
  OFFSET for the pose); joints without position channels hold their OFFSET.
* Quaternions are made hemisphere-continuous along time per joint.
"""

import math
import numpy as np

from spec_filters import make_continuous, qmul  # noqa: F401 (make_continuous is re-exported)

AXES = "XYZ"
ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")


class Motion:
    """A BVH clip.

    names[j], parents[j] (-1 for the root), offsets[j] (3,), channels[j] (list
    of channel names as in the file), end_sites[j] (list of (3,) offsets of
    the End Sites that are children of joint j), frame_time (float),
    frame_time_str (the text as found in the file), q (F, J, 4) float64 local
    rotations (wxyz), p (F, J, 3) float64 local translations, has_pos (J,)
    bool, rot_order[j] (e.g. "ZYX" or "" when the joint has no rotation).
    """

    def __init__(self):
        self.names = []
        self.parents = []
        self.offsets = []
        self.channels = []
        self.end_sites = []
        self.frame_time = 1.0 / 30.0
        self.frame_time_str = None
        self.q = None
        self.p = None
        self.has_pos = None
        self.rot_order = []

    @property
    def F(self):
        return self.q.shape[0]

    @property
    def J(self):
        return len(self.names)

    def copy(self):
        m = Motion()
        m.names = list(self.names)
        m.parents = list(self.parents)
        m.offsets = [np.array(o, dtype=float) for o in self.offsets]
        m.channels = [list(c) for c in self.channels]
        m.end_sites = [[np.array(e, dtype=float) for e in es] for es in self.end_sites]
        m.frame_time = self.frame_time
        m.frame_time_str = self.frame_time_str
        m.q = self.q.copy()
        m.p = self.p.copy()
        m.has_pos = self.has_pos.copy()
        m.rot_order = list(self.rot_order)
        return m


# ----------------------------------------------------------------------------
# quaternion helpers: the oracle's own (spec_filters.py), one definition of each

def _axis_quat(axis, angle_rad):
    """Quaternion of a rotation by angle (array) about X/Y/Z."""
    angle_rad = np.asarray(angle_rad, dtype=float)
    q = np.zeros(angle_rad.shape + (4,))
    q[..., 0] = np.cos(angle_rad / 2)
    q[..., 1 + AXES.index(axis)] = np.sin(angle_rad / 2)
    return q


def euler_to_quat(order, angles_deg):
    """order: e.g. "ZYX" (file order); angles_deg (..., 3) in that order.
    Returns q = q_order[0](a0) * q_order[1](a1) * q_order[2](a2)."""
    a = np.radians(np.asarray(angles_deg, dtype=float))
    q = _axis_quat(order[0], a[..., 0])
    for n in (1, 2):
        q = qmul(q, _axis_quat(order[n], a[..., n]))
    return q


def quat_to_matrix(q):
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 2, 1] = 2 * (y * z + w * x)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def quat_to_euler(order, q):
    """Inverse of euler_to_quat: angles (..., 3) in degrees, in file order,
    such that R = R_order[0](a) R_order[1](b) R_order[2](c).

    With (i, j, k) the axis indices of the order and s = +1 for a cyclic
    order (XYZ, YZX, ZXY), -1 otherwise:
        b = atan2(s R[i,k], hypot(R[i,i], R[i,j]))
        a = atan2(-s R[j,k], R[k,k]),  c = atan2(-s R[i,j], R[i,i])
    At gimbal lock (cos b ~ 0) c := 0 and a absorbs the rest.
    """
    i, j, k = (AXES.index(ch) for ch in order)
    s = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    R = quat_to_matrix(np.asarray(q, dtype=float))
    cb = np.hypot(R[..., i, i], R[..., i, j])
    b = np.arctan2(s * R[..., i, k], cb)
    a = np.arctan2(-s * R[..., j, k], R[..., k, k])
    c = np.arctan2(-s * R[..., i, j], R[..., i, i])
    lock = cb < 1e-10
    if np.any(lock):
        # R = R_i(a) R_j(+-pi/2) with c = 0: a from the (k, j) / (j, j) entries
        a_l = np.arctan2(s * R[..., k, j], R[..., j, j])
        a = np.where(lock, a_l, a)
        c = np.where(lock, 0.0, c)
    return np.degrees(np.stack([a, b, c], axis=-1))


# ----------------------------------------------------------------------------
# reader

def _tokens(text):
    for line in text.splitlines():
        for tok in line.split():
            yield tok


def read_bvh(path):
    with open(path, "r") as fh:
        text = fh.read()
    head, sep, motion_txt = text.partition("MOTION")
    if not sep:
        raise ValueError("%s: no MOTION section" % path)
    m = Motion()
    toks = list(_tokens(head))
    pos = 0
    stack = []          # joint index (or None for End Site) per open brace
    pending = None      # ("joint", name) or ("end",) awaiting its "{"
    if not toks or toks[0] != "HIERARCHY":
        raise ValueError("%s: no HIERARCHY" % path)
    pos = 1
    while pos < len(toks):
        t = toks[pos]
        if t in ("ROOT", "JOINT"):
            pending = ("joint", toks[pos + 1])
            pos += 2
        elif t == "End":
            pending = ("end",)
            pos += 2            # "End Site"
        elif t == "{":
            parent = None
            for s in reversed(stack):
                if s is not None and s >= 0:
                    parent = s
                    break
            if pending[0] == "joint":
                m.names.append(pending[1])
                m.parents.append(-1 if parent is None else parent)
                m.offsets.append(np.zeros(3))
                m.channels.append([])
                m.end_sites.append([])
                stack.append(len(m.names) - 1)
            else:
                m.end_sites[parent].append(np.zeros(3))
                stack.append(-1 - parent)   # marks an End Site of parent
            pending = None
            pos += 1
        elif t == "}":
            stack.pop()
            pos += 1
        elif t == "OFFSET":
            vals = np.array([float(v) for v in toks[pos + 1:pos + 4]])
            cur = stack[-1]
            if cur >= 0:
                m.offsets[cur] = vals
            else:
                m.end_sites[-1 - cur][-1] = vals
            pos += 4
        elif t == "CHANNELS":
            n = int(toks[pos + 1])
            m.channels[stack[-1]] = toks[pos + 2:pos + 2 + n]
            pos += 2 + n
        else:
            raise ValueError("%s: unexpected token %r in HIERARCHY" % (path, t))

    mt = motion_txt.split()
    # Frames: N  Frame Time: T  numbers...
    i = 0
    nframes = None
    ft = None
    while i < len(mt):
        if mt[i] == "Frames:":
            nframes = int(mt[i + 1]); i += 2
        elif mt[i] == "Frame" and mt[i + 1] == "Time:":
            ft = mt[i + 2]; i += 3
            break
        else:
            raise ValueError("%s: unexpected %r in MOTION header" % (path, mt[i]))
    m.frame_time_str = ft
    m.frame_time = float(ft)
    nch = sum(len(c) for c in m.channels)
    data = np.array([float(v) for v in mt[i:]], dtype=float)
    if data.size != nframes * nch:
        raise ValueError("%s: %d values, expected %d frames x %d channels"
                         % (path, data.size, nframes, nch))
    data = data.reshape(nframes, nch)
    J = len(m.names)
    m.q = np.zeros((nframes, J, 4)); m.q[..., 0] = 1.0
    m.p = np.tile(np.array(m.offsets)[None], (nframes, 1, 1)).astype(float)
    m.has_pos = np.zeros(J, dtype=bool)
    col = 0
    for j, chans in enumerate(m.channels):
        rot_axes = []
        rot_cols = []
        for c in chans:
            kind = c[1:]
            ax = c[0].upper()
            if kind.lower() == "position":
                m.p[:, j, AXES.index(ax)] = data[:, col]
                m.has_pos[j] = True
            elif kind.lower() == "rotation":
                rot_axes.append(ax)
                rot_cols.append(col)
            else:
                raise ValueError("%s: unknown channel %r" % (path, c))
            col += 1
        order = "".join(rot_axes)
        m.rot_order.append(order)
        if order:
            q = _axis_quat(order[0], np.radians(data[:, rot_cols[0]]))
            for ax, cc in zip(order[1:], rot_cols[1:]):
                q = qmul(q, _axis_quat(ax, np.radians(data[:, cc])))
            m.q[:, j] = q
    m.q = make_continuous(m.q)
    return m


# ----------------------------------------------------------------------------
# writer

def set_layout(m, rot_orders, pos_on=None):
    """Give joint j the rotation order rot_orders[j] and, where pos_on[j],
    position channels Xposition Yposition Zposition (listed first)."""
    if pos_on is None:
        pos_on = m.has_pos
    m.has_pos = np.array(pos_on, dtype=bool)
    m.rot_order = list(rot_orders)
    m.channels = []
    for j in range(m.J):
        ch = []
        if m.has_pos[j]:
            ch += ["Xposition", "Yposition", "Zposition"]
        ch += ["%srotation" % a for a in m.rot_order[j]]
        m.channels.append(ch)
    return m


def _fmt(v):
    s = "%.9g" % v
    if s == "-0":
        s = "0"
    return s


def write_bvh(m, path, fmt=_fmt):
    """Write m with its current channel layout (m.channels)."""
    lines = ["HIERARCHY"]
    children = [[] for _ in range(m.J)]
    for j, pa in enumerate(m.parents):
        if pa >= 0:
            children[pa].append(j)

    def emit(j, depth):
        ind = "\t" * depth
        lines.append("%s%s %s" % (ind, "ROOT" if m.parents[j] < 0 else "JOINT", m.names[j]))
        lines.append(ind + "{")
        lines.append("%s\tOFFSET %s" % (ind, " ".join(fmt(v) for v in m.offsets[j])))
        lines.append("%s\tCHANNELS %d %s" % (ind, len(m.channels[j]), " ".join(m.channels[j])))
        for c in children[j]:
            emit(c, depth + 1)
        for e in m.end_sites[j]:
            lines.append(ind + "\tEnd Site")
            lines.append(ind + "\t{")
            lines.append("%s\t\tOFFSET %s" % (ind, " ".join(fmt(v) for v in e)))
            lines.append(ind + "\t}")
        lines.append(ind + "}")

    for j in range(m.J):
        if m.parents[j] < 0:
            emit(j, 0)
    lines.append("MOTION")
    lines.append("Frames: %d" % m.F)
    lines.append("Frame Time: %s" % (m.frame_time_str or ("%.9g" % m.frame_time)))
    # columns
    cols = []
    for j in range(m.J):
        rot_ch = [c[0] for c in m.channels[j] if c[1:].lower() == "rotation"]
        order = "".join(rot_ch)
        eul = quat_to_euler(order, m.q[:, j]) if order else None
        for c in m.channels[j]:
            ax = AXES.index(c[0].upper())
            if c[1:].lower() == "position":
                cols.append(m.p[:, j, ax])
            else:
                cols.append(eul[:, order.index(c[0].upper())])
    data = np.stack(cols, axis=1) if cols else np.zeros((m.F, 0))
    for row in data:
        lines.append(" ".join(fmt(v) for v in row))
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")


def _selftest():
    rng = np.random.default_rng(1)
    for order in ORDERS:
        q = rng.normal(size=(2000, 4))
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
        # plus gimbal-lock cases
        mid = order[1]
        lock = np.stack([euler_to_quat(order, [a, sgn * 90.0, c])
                         for a, c, sgn in [(10, 20, 1), (-170, 35, -1), (0, 0, 1)]])
        q = np.concatenate([q, lock])
        e = quat_to_euler(order, q)
        q2 = euler_to_quat(order, e)
        err = np.abs(np.einsum("nc,nc->n", q, q2))
        assert np.all(err > 1 - 1e-12), (order, err.min())
        # composition order: R = R_first R_second R_third on a matrix level
        a, b, c = 30.0, -40.0, 75.0
        R = quat_to_matrix(euler_to_quat(order, [a, b, c]))

        def rot(ax, deg):
            t = math.radians(deg); cs, sn = math.cos(t), math.sin(t)
            i = AXES.index(ax)
            M = np.eye(3)
            j, k = (i + 1) % 3, (i + 2) % 3
            M[j, j] = cs; M[j, k] = -sn; M[k, j] = sn; M[k, k] = cs
            return M
        R2 = rot(order[0], a) @ rot(order[1], b) @ rot(order[2], c)
        assert np.allclose(R, R2, atol=1e-12), order
    print("bvh self-test ok")


if __name__ == "__main__":
    _selftest()
