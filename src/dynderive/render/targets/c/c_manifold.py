"""C lines of a floating-base robot's configuration space (``c_floating.py``): the neutral
configuration, ``integrate``, ``difference`` and ``configuration_rate`` on Pinocchio's
conventions, the same formulas as the NumPy module's (``templates/floating_dynamics.py.j2``):
a floating joint's pose times the exponential of its twist (SE(3)), a spherical joint's
quaternion times the exponential of its angular velocity (SO(3): no change of hemisphere, as
Pinocchio), ``q + v dt`` for the others.

Each joint's lines are a block (``{ ... }``) of constants, unrolled for its place in ``q``
and ``v``: no helper function (an unused static function is a warning), no loop.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Below this angle the exponential and the logarithm use their series (as the NumPy module).
SMALL = "1e-4"


@dataclass(frozen=True)
class ManifoldJoint:
    """A moving joint's kind (``floating``, ``spherical`` or ``scalar``) and where its entries
    start in ``q`` and in ``v``."""

    kind: str
    q: int
    v: int


def _cross(out: str, a: tuple[str, str, str], b: tuple[str, str, str]) -> list[str]:
    return [f"const double {out}x = {a[1]}*{b[2]} - {a[2]}*{b[1]};",
            f"const double {out}y = {a[2]}*{b[0]} - {a[0]}*{b[2]};",
            f"const double {out}z = {a[0]}*{b[1]} - {a[1]}*{b[0]};"]


def _vec(name: str) -> tuple[str, str, str]:
    return (f"{name}x", f"{name}y", f"{name}z")


def _rotate(out: str, quaternion: tuple[str, str, str, str], vector: tuple[str, str, str]) -> list[str]:
    """``vector`` rotated by ``quaternion`` (x, y, z, w): v + w t + u x t, t = 2 u x v."""
    u = quaternion[:3]
    lines = _cross(f"{out}_c", u, vector)
    lines += [f"const double {out}_tx = 2.0*{out}_cx;", f"const double {out}_ty = 2.0*{out}_cy;",
              f"const double {out}_tz = 2.0*{out}_cz;"]
    lines += _cross(f"{out}_d", u, _vec(f"{out}_t"))
    return lines + [f"const double {out}{a} = {vector[i]} + {quaternion[3]}*{out}_t{a} + {out}_d{a};"
                    for i, a in enumerate("xyz")]


def _multiply(out: str, a: tuple[str, ...], b: tuple[str, ...]) -> list[str]:
    """The quaternion product a b, (x, y, z, w): (s v + t u + u x v, s t - u . v)."""
    lines = _cross(f"{out}_c", a[:3], b[:3])
    lines += [f"const double {out}{c} = {a[3]}*{b[i]} + {b[3]}*{a[i]} + {out}_c{c};" for i, c in enumerate("xyz")]
    return lines + [f"const double {out}w = {a[3]}*{b[3]} - ({a[0]}*{b[0]} + {a[1]}*{b[1]} + {a[2]}*{b[2]});"]


def _quaternion(array: str, start: int) -> tuple[str, str, str, str]:
    return tuple(f"{array}[{start + k}]" for k in range(4))   # type: ignore[return-value]


def _exp_rotation(w: tuple[str, str, str]) -> list[str]:
    """``theta``, ``t`` (theta, or 1 when small) and the step quaternion ``e`` of exp(w)."""
    return [f"const double theta = sqrt({w[0]}*{w[0]} + {w[1]}*{w[1]} + {w[2]}*{w[2]});",
            f"const int small = theta < {SMALL};",
            "const double t = small ? 1.0 : theta;",
            "const double half_sinc = small ? 0.5 - theta*theta/48.0 : sin(t/2.0)/t;",
            *(f"const double e{c} = half_sinc*{w[i]};" for i, c in enumerate("xyz")),
            "const double ew = cos(theta/2.0);"]


def _moved(q: str, start: int, out: str, hemisphere: bool) -> list[str]:
    """``m = q_quaternion * e``, normalized (in the hemisphere of q's for a floating joint, as
    Pinocchio's SE(3); a spherical joint's, as its SO(3), keeps its sign), written to ``out``."""
    quaternion = _quaternion(q, start)
    lines = _multiply("m", quaternion, ("ex", "ey", "ez", "ew"))
    lines.append("const double norm = sqrt(mx*mx + my*my + mz*mz + mw*mw);")
    if not hemisphere:
        return lines + [f"{out}[{start + k}] = m{c}/norm;" for k, c in enumerate("xyzw")]
    lines.append(f"const double sign = (mx*{quaternion[0]} + my*{quaternion[1]} + mz*{quaternion[2]} + "
                 f"mw*{quaternion[3]}) < 0.0 ? -1.0 : 1.0;")
    return lines + [f"{out}[{start + k}] = sign*m{c}/norm;" for k, c in enumerate("xyzw")]


def integrate_lines(joints: list[ManifoldJoint]) -> list[str]:
    """``out = integrate(q, v * dt)``."""
    lines: list[str] = []
    for joint in joints:
        if joint.kind == "scalar":
            lines.append(f"out[{joint.q}] = q[{joint.q}] + v[{joint.v}]*dt;")
            continue
        block = []
        if joint.kind == "floating":
            block += [f"const double l{c} = v[{joint.v + k}]*dt;" for k, c in enumerate("xyz")]
            block += [f"const double r{c} = v[{joint.v + 3 + k}]*dt;" for k, c in enumerate("xyz")]
            block += _exp_rotation(_vec("r"))
            block += ["const double a = small ? 0.5 - theta*theta/24.0 : (1.0 - cos(t))/(t*t);",
                      "const double b = small ? 1.0/6.0 - theta*theta/120.0 : (t - sin(t))/(t*t*t);"]
            block += _cross("wv", _vec("r"), _vec("l"))
            block += _cross("wwv", _vec("r"), _vec("wv"))
            block += [f"const double p{c} = l{c} + a*wv{c} + b*wwv{c};" for c in "xyz"]
            block += _rotate("s", _quaternion("q", joint.q + 3), _vec("p"))
            block += [f"out[{joint.q + k}] = q[{joint.q + k}] + s{c};" for k, c in enumerate("xyz")]
            block += _moved("q", joint.q + 3, "out", hemisphere=True)
        else:
            block += [f"const double r{c} = v[{joint.v + k}]*dt;" for k, c in enumerate("xyz")]
            block += _exp_rotation(_vec("r"))
            block += _moved("q", joint.q, "out", hemisphere=False)
        lines += ["{", *(f"    {line}" for line in block), "}"]
    return lines


def _log_rotation(r: tuple[str, str, str, str]) -> list[str]:
    """``w``: the angular velocity whose exponential is the unit quaternion ``r``, and
    ``theta``, ``small`` (as ``_exp_rotation``)."""
    return [f"const double flip = {r[3]} < 0.0 ? -1.0 : 1.0;",
            *(f"const double h{c} = flip*{r[i]};" for i, c in enumerate("xyz")),
            f"const double c = flip*{r[3]};",
            "const double s = sqrt(hx*hx + hy*hy + hz*hz);",
            "const double theta = 2.0*atan2(s, c);",
            f"const int small = theta < {SMALL};",
            "const double scale = small ? 2.0 + theta*theta/12.0 : theta/(s == 0.0 ? 1.0 : s);",
            *(f"const double w{c} = scale*h{c};" for c in "xyz")]


def difference_lines(joints: list[ManifoldJoint]) -> list[str]:
    """``v`` with ``integrate(q0, v, 1) = q1``."""
    lines: list[str] = []
    for joint in joints:
        if joint.kind == "scalar":
            lines.append(f"v[{joint.v}] = q1[{joint.q}] - q0[{joint.q}];")
            continue
        start = joint.q + 3 if joint.kind == "floating" else joint.q
        a, b = _quaternion("q0", start), _quaternion("q1", start)
        block = [f"const double n2 = {a[0]}*{a[0]} + {a[1]}*{a[1]} + {a[2]}*{a[2]} + {a[3]}*{a[3]};",
                 *(f"const double i{c} = -{a[k]}/n2;" for k, c in enumerate("xyz")),
                 f"const double iw = {a[3]}/n2;"]
        block += _multiply("m", ("ix", "iy", "iz", "iw"), b)
        block += ["const double norm = sqrt(mx*mx + my*my + mz*mz + mw*mw);",
                  *(f"const double r{c} = m{c}/norm;" for c in "xyzw")]
        block += _log_rotation(("rx", "ry", "rz", "rw"))
        if joint.kind == "floating":
            block += [f"const double d{c} = q1[{joint.q + k}] - q0[{joint.q + k}];" for k, c in enumerate("xyz")]
            block += _rotate("p", ("ix", "iy", "iz", "iw"), _vec("d"))
            block += ["const double t = small ? 1.0 : theta;",
                      "const double k = small ? 1.0/12.0 + theta*theta/720.0 : "
                      "(1.0 - t*sin(t)/(2.0*(1.0 - cos(t))))/(t*t);"]
            block += _cross("wp", _vec("w"), _vec("p"))
            block += _cross("wwp", _vec("w"), _vec("wp"))
            block += [f"v[{joint.v + k}] = p{c} - 0.5*wp{c} + k*wwp{c};" for k, c in enumerate("xyz")]
            block += [f"v[{joint.v + 3 + k}] = w{c};" for k, c in enumerate("xyz")]
        else:
            block += [f"v[{joint.v + k}] = w{c};" for k, c in enumerate("xyz")]
        lines += ["{", *(f"    {line}" for line in block), "}"]
    return lines


def rate_lines(joints: list[ManifoldJoint]) -> list[str]:
    """``out = dq/dt`` at velocity ``v``: a quaternion's rate 1/2 quaternion * (w, 0), a
    floating joint's position rate R(quaternion) (vx, vy, vz)."""
    lines: list[str] = []
    for joint in joints:
        if joint.kind == "scalar":
            lines.append(f"out[{joint.q}] = v[{joint.v}];")
            continue
        start, spin = (joint.q + 3, joint.v + 3) if joint.kind == "floating" else (joint.q, joint.v)
        quaternion = _quaternion("q", start)
        block = _multiply("m", quaternion, (f"v[{spin}]", f"v[{spin + 1}]", f"v[{spin + 2}]", "0.0"))
        block += [f"out[{start + k}] = 0.5*m{c};" for k, c in enumerate("xyzw")]
        if joint.kind == "floating":
            block += _rotate("s", quaternion, tuple(f"v[{joint.v + k}]" for k in range(3)))   # type: ignore[arg-type]
            block += [f"out[{joint.q + k}] = s{c};" for k, c in enumerate("xyz")]
        lines += ["{", *(f"    {line}" for line in block), "}"]
    return lines


def neutral_lines(joints: list[ManifoldJoint], nq: int) -> list[str]:
    """Zeros, and identity quaternions (w = 1)."""
    ones = [j.q + 6 if j.kind == "floating" else j.q + 3 for j in joints if j.kind != "scalar"]
    return [f"for (int i = 0; i < {nq}; ++i) q[i] = 0.0;", *(f"q[{i}] = 1.0;" for i in ones)]


__all__ = ["ManifoldJoint", "difference_lines", "integrate_lines", "neutral_lines", "rate_lines"]
