#!/usr/bin/env python3
"""Far upper-tail values of the studentized range, P(Q(k, nu) > q), with mpmath.

Independent of palplab's C++ code (different quadrature, special functions and precision):
mpmath at 30 digits (its exponent range has no underflow, so values far below 1e-308 are
exact to the digits shown) on composite Gauss-Legendre rules. The integrand is the
cancellation-free upper form
    P(R > w) = k * int phi(z) Q(z)^(k-1) * (1 - (1 - Q(z+w)/Q(z))^(k-1)) dz
    P(Q > q) = int f_S(s) P(R > q s) ds,   S = sqrt(chi2_nu / nu).
Self-checks printed to stderr: k = 2 against the closed form P(|T_nu| > q / sqrt 2), and two
values recomputed with 1.5x the nodes (the relative change bounds the quadrature error).
Run: python3 far_tail_mpmath.py > far_tail_mpmath.out   (mpmath 1.3.0)
"""
import sys

import mpmath as mp

mp.mp.dps = 30


def rule(n):
    """Gauss-Legendre nodes and weights on [-1, 1] by Newton's method on P_n."""
    xs, ws = [], []
    for i in range(n):
        z = mp.cos(mp.pi * (i + mp.mpf(0.75)) / (n + mp.mpf(0.5)))
        for _ in range(100):
            p0, p1 = mp.mpf(1), z
            for j in range(2, n + 1):
                p0, p1 = p1, ((2 * j - 1) * z * p1 - (j - 1) * p0) / j
            dp = n * (z * p1 - p0) / (z * z - 1)
            dz = p1 / dp
            z -= dz
            if abs(dz) < mp.mpf(10) ** (-mp.mp.dps + 2):
                break
        xs.append(z)
        ws.append(2 / ((1 - z * z) * dp * dp))
    return xs, ws


def composite(f, pts, rl):
    xs, ws = rl
    total = mp.mpf(0)
    for a, b in zip(pts[:-1], pts[1:]):
        c, h = (a + b) / 2, (b - a) / 2
        total += h * mp.fsum(w * f(c + h * x) for x, w in zip(xs, ws))
    return total


def range_upper(w, k, rl):
    m = k - 1
    sq2 = mp.sqrt(2)

    def f(z):
        a = mp.erfc(z / sq2) / 2
        r = (mp.erfc((z + w) / sq2) / 2) / a
        return k * mp.npdf(z) * a**m * (-mp.expm1(m * mp.log1p(-r)))

    c = -w / 2
    # Beyond |z - c| = 20 the integrand is < e^-190 of its peak.
    pts = [c + d for d in (-20, -12, -8, -5, -3, -1.5, 0, 1.5, 3, 5, 8, 12, 20)]
    return composite(f, pts, rl)


def sr_sf(q, k, nu, n):
    rl = rule(n)
    q, nu = mp.mpf(q), mp.mpf(nu)
    lognorm = mp.log(2) + nu / 2 * mp.log(nu / 2) - mp.loggamma(nu / 2)

    def dens(s):
        return mp.exp(lognorm + (nu - 1) * mp.log(s) - nu * s * s / 2)

    # density x tail ~ s^(nu-1) exp(-(nu + q^2/2) s^2 / 2): peak sp, width sd.
    sp = mp.sqrt(max(nu - 1, mp.mpf(0.5)) / (nu + q * q / 2))
    sd = 1 / mp.sqrt(2 * (nu + q * q / 2))
    pts = sorted(set([sp / 64] + [sp + d * sd for d in (-16, -10, -6, -4, -2, -1, 0, 1, 2, 4, 6,
                                                        10, 16, 24, 40) if sp + d * sd > sp / 64]))
    return composite(lambda s: dens(s) * range_upper(q * s, k, rl), pts, rl)


if __name__ == "__main__":
    for q, nu in ((30, 40), (60, 200)):
        t = mp.mpf(q) / mp.sqrt(2)
        exact = mp.betainc(mp.mpf(nu) / 2, mp.mpf(1) / 2, 0, nu / (nu + t * t), regularized=True)
        got = sr_sf(q, 2, nu, 20)
        print("check k=2 q=%s nu=%s: %s, closed form %s, rel %s" %
              (q, nu, mp.nstr(got, 12), mp.nstr(exact, 12), mp.nstr(abs(got / exact - 1), 3)),
              file=sys.stderr, flush=True)
    cases = [(8, 3, 20), (30, 4, 60), (40, 9, 100), (50, 5, 400), (52, 9, 4000),
             (25, 30, 1500), (40, 20, 120), (60, 9, 4000), (89.5, 9, 4000)]
    print("# q k nu sf   (P(Q > q), mpmath, 30 digits, 20-point rules)")
    for i, (q, k, nu) in enumerate(cases):
        v = sr_sf(q, k, nu, 20)
        if i in (1, 4):
            v2 = sr_sf(q, k, nu, 30)
            print("check q=%s k=%d nu=%s: 20 vs 30 nodes rel %s" %
                  (q, k, nu, mp.nstr(abs(v / v2 - 1), 3)), file=sys.stderr, flush=True)
        print("%s %d %s %s" % (q, k, nu, mp.nstr(v, 17)), flush=True)
