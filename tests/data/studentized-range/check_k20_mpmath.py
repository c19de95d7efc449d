# Independent mpmath check of the k = 20, q = 0.1 lower tails, where the scipy reference
# values fall below the nu = infinity limit (impossible: P(Q <= q) decreases to it as nu grows).
#   python3 check_k20_mpmath.py   (mpmath 1.3.0; output committed as check_k20_mpmath.out)
import mpmath as mp
mp.mp.dps = 30
def range_cdf(w, k):
    f = lambda z: k*mp.npdf(z)*(mp.ncdf(z+w)-mp.ncdf(z))**(k-1)
    return mp.quad(f, [-mp.inf, -w/2-2, -w/2, -w/2+2, mp.inf])
def sr_cdf(q, k, v):
    v = mp.mpf(v)
    lognorm = mp.log(2) + v/2*mp.log(v/2) - mp.loggamma(v/2)
    dens = lambda s: mp.exp(lognorm + (v-1)*mp.log(s) - v*s*s/2)
    sl = mp.sqrt((v+k-2)/v); w = 1/mp.sqrt(2*v)
    pts = [0, sl-8*w*sl, sl-3*w*sl, sl, sl+3*w*sl, sl+8*w*sl, 4*sl, mp.inf]
    return mp.quad(lambda s: dens(s)*range_cdf(q*s, k), pts)
for v in [3, 120]:  # scipy reference: 9.539763646681808e-22, 4.9192317333541143e-28
    print(v, mp.nstr(sr_cdf(mp.mpf('0.1'), 20, v), 15), flush=True)
print('inf', mp.nstr(range_cdf(mp.mpf('0.1'), 20), 15), flush=True)
