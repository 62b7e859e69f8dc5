"""Derives the polynomial coefficients used by src/math (near-minimax fits with mpmath).

    python3 tools/fit_poly.py

Each fit prints the coefficients rounded to f32 and the max relative error of the
rounded polynomial (in f64, i.e. the approximation error alone) on its domain.
"""
import mpmath as mp
import struct

mp.mp.dps = 40

def f32(x):
    return struct.unpack('f', struct.pack('f', float(x)))[0]

def fit(name, f, lo, hi, deg, weight=None):
    # Chebyshev fit, then a few Remez-like corrections by refitting with mpmath's
    # chebyfit on the relative error (good to a fraction of a bit for these smooth kernels).
    poly, err = mp.chebyfit(f, [lo, hi], deg + 1, error=True)
    coeffs = [f32(c) for c in poly]  # highest degree first
    worst = 0
    for i in range(2001):
        x = lo + (hi - lo) * i / 2000
        p = mp.polyval(coeffs, x)
        v = f(x)
        if v != 0:
            worst = max(worst, abs((p - v) / v))
    print(f"{name}: degree {deg} on [{lo}, {hi}]  max rel err of f32 coeffs {float(worst):.3e}")
    for c in coeffs:
        print(f"    {c!r}_f32,")
    return coeffs

ln2 = mp.log(2)
# exp: e^r = 1 + r + r^2 Q(r), r in [-ln2/2, ln2/2]
Q = lambda r: (mp.exp(r) - 1 - r) / r**2 if r != 0 else mp.mpf(1) / 2
fit("exp Q", Q, -ln2 / 2, ln2 / 2, 4)
fit("expm1 Q", Q, -ln2 / 2, ln2 / 2, 5)

# exp2_nonpos and exp2m1 (the framebuffer pass): 2^f = 1 + f P(f), f in [-1/2, 1/2].
# The printed error is that of P; for exp2_nonpos the error of 1 + f P(f) against 2^f
# is what counts (9.2e-9 for degree 5), for exp2m1 that of f P(f) against 2^f - 1,
# i.e. P's own (5.6e-9 for degree 6).
P2 = lambda f: (mp.power(2, f) - 1) / f if f != 0 else ln2
c5 = fit("exp2 P (exp2_nonpos)", P2, -0.5, 0.5, 5)
worst = max(abs((1 + f * mp.polyval(c5, f)) / mp.power(2, f) - 1)
            for f in (mp.mpf(i) / 4000 - mp.mpf(1) / 2 for i in range(4001)))
print(f"    1 + f P(f) against 2^f: max rel err {float(worst):.3e}")
fit("exp2 P (exp2m1, degree 6 until the forty-fifth session)", P2, -0.5, 0.5, 6)


def tune_f32(coeffs, f, lo, hi, keep_last=True):
    """Moves each f32 coefficient (highest degree first, as `fit` returns them) by up to
    4 ULP, then pairs by up to 2, while the max relative error over 2001 points falls;
    the constant term stays (keep_last)."""
    def ulp_step(x, k):
        b = struct.unpack('I', struct.pack('f', x))[0]
        b = b + k if x > 0 else b - k
        return struct.unpack('f', struct.pack('I', b))[0]
    pts = [lo + (hi - lo) * i / 2000 for i in range(2001)]
    pts = [x for x in pts if x != 0]
    ref = [float(f(mp.mpf(x))) for x in pts]

    def err(c):
        w = 0.0
        for x, r in zip(pts, ref):
            p = 0.0
            for a in c:
                p = p * x + a
            w = max(w, abs(p / r - 1))
        return w
    c = list(coeffs)
    movable = range(len(c) - 1) if keep_last else range(len(c))
    best = err(c)
    improved = True
    while improved:
        improved = False
        for i in movable:
            for d in (-4, -3, -2, -1, 1, 2, 3, 4):
                cc = list(c)
                cc[i] = ulp_step(c[i], d)
                e = err(cc)
                if e < best:
                    best, c, improved = e, cc, True
        if not improved:
            for i in movable:
                for j in movable:
                    if j <= i:
                        continue
                    for di in (-2, -1, 1, 2):
                        for dj in (-2, -1, 1, 2):
                            cc = list(c)
                            cc[i] = ulp_step(c[i], di)
                            cc[j] = ulp_step(c[j], dj)
                            e = err(cc)
                            if e < best:
                                best, c, improved = e, cc, True
    return c, best


# exp2m1 since the forty-fifth session: degree 5, the f32 coefficients tuned (1.64e-8
# against the rounded fit's 2.2e-8); the kernel stores them doubled.
c5m, e5m = tune_f32(fit("exp2 P (exp2m1)", P2, -0.5, 0.5, 5), P2, -0.5, 0.5)
print(f"    tuned: max rel err {e5m:.3e}; doubled:", [repr(2 * x) for x in c5m])

# exp2_nonpos_table: 2^r = 1 + r P(r), r in [-1/32, 1/32] (y less its nearest multiple of
# 1/16); the table of 2^(j/16) takes the rest. 2.4e-9 for degree 2 (0.04 ULP).
c2 = fit("exp2 P (exp2_nonpos_table)", P2, -mp.mpf(1) / 32, mp.mpf(1) / 32, 2)
worst = max(abs((1 + r * mp.polyval(c2, r)) / mp.power(2, r) - 1)
            for r in (mp.mpf(i) / 64000 - mp.mpf(1) / 32 for i in range(4001)))
print(f"    1 + r P(r) against 2^r: max rel err {float(worst):.3e}")
print("    table 2^(j/16), j = 0..15:", [f32(mp.power(2, mp.mpf(j) / 16)) for j in range(16)])

# exp_neg: 2^r = 1 + r P(r), r in [-1/16, 1/16] (y less its nearest multiple of 1/8), with
# 2^(j/8) = hi + lo = hi·(1 + lo_rel) in two f32 tables (hi and lo_rel). 3.4e-10 for degree 3 (0.006 ULP).
c3 = fit("exp2 P (exp_neg)", P2, -mp.mpf(1) / 16, mp.mpf(1) / 16, 3)
worst = max(abs((1 + r * mp.polyval(c3, r)) / mp.power(2, r) - 1)
            for r in (mp.mpf(i) / 32000 - mp.mpf(1) / 16 for i in range(4001)))
print(f"    1 + r P(r) against 2^r: max rel err {float(worst):.3e}")
hi = [f32(mp.power(2, mp.mpf(j) / 8)) for j in range(8)]
print("    table hi 2^(j/8), j = 0..7:", hi)
print("    table lo 2^(j/8) - hi:", [f32(mp.power(2, mp.mpf(j) / 8) - hi[j]) for j in range(8)])
print("    table lo_rel (2^(j/8) - hi) / hi:",
      [f32((mp.power(2, mp.mpf(j) / 8) - hi[j]) / hi[j]) for j in range(8)])
l2e = f32(1 / mp.log(2))
print("    log2(e) hi, lo:", l2e, f32(1 / mp.log(2) - l2e))
