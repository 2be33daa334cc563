"""Pose maths of the robot-side tools and their tests: a pose is (t, q) with t a 3-tuple in metres
and q = (x, y, z, w) a unit quaternion; compose(a, b) maps frame b's points through a."""
import math


def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def qconj(q):
    return (-q[0], -q[1], -q[2], q[3])


def qrot(q, v):
    x, y, z, _ = qmul(qmul(q, (v[0], v[1], v[2], 0.0)), qconj(q))
    return (x, y, z)


def qnorm(q):
    n = math.sqrt(sum(c * c for c in q))
    q = tuple(c / n for c in q)
    return q if q[3] >= 0 else tuple(-c for c in q)


def compose(a, b):
    ta, qa = a
    tb, qb = b
    r = qrot(qa, tb)
    return ((ta[0] + r[0], ta[1] + r[1], ta[2] + r[2]), qnorm(qmul(qa, qb)))


def inverse(a):
    t, q = a
    qi = qconj(q)
    r = qrot(qi, t)
    return ((-r[0], -r[1], -r[2]), qi)


def slerp(q0, q1, s):
    d = sum(a * b for a, b in zip(q0, q1))
    if d < 0:
        q1, d = tuple(-c for c in q1), -d
    if d > 0.9995:
        return qnorm(tuple(a + s * (b - a) for a, b in zip(q0, q1)))
    th = math.acos(d)
    w0, w1 = math.sin((1 - s) * th) / math.sin(th), math.sin(s * th) / math.sin(th)
    return qnorm(tuple(w0 * a + w1 * b for a, b in zip(q0, q1)))


def interpolate(a, b, s):
    """The pose a fraction s of the way from pose a to pose b: translation lerp, rotation slerp (as
    edgefused interpolates its pose sources, so the robot tools describe the same path)."""
    (ta, qa), (tb, qb) = a, b
    return (tuple(x + s * (y - x) for x, y in zip(ta, tb)), slerp(qa, qb, s))


def axis_angle(axis, rad):
    s = math.sin(rad / 2)
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(rad / 2))


def angle_deg(a, b):
    """The rotation angle between two quaternions (either sign), degrees."""
    d = abs(sum(x * y for x, y in zip(a, b))) / math.sqrt(sum(x * x for x in a) * sum(y * y for y in b))
    return math.degrees(2 * math.acos(min(1.0, d)))
