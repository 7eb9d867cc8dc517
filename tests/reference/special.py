"""Reference values for src/analysis/special.rs (scipy). Run: python3 tests/reference/special.py
Prints Rust-ready tuples; pasted into the tests in src/analysis/special.rs."""
import scipy, numpy as np
from scipy import special as sp, stats as st
print("# scipy", scipy.__version__)
print("// ln_gamma: (x, lgamma(x))")
for x in [1e-8, 0.1, 0.5, 1.5, 2.5, 3.7, 10.0, 33.3, 171.5, 1e4, 1e8, -0.5, -2.7]:
    print(f"({x!r}, {float(sp.gammaln(x))!r}),")
print("// gamma_p: (a, x, P(a,x), Q(a,x))")
for a, x in [(0.5, 0.1), (0.5, 2.0), (1.0, 1.0), (2.5, 0.7), (5.0, 5.0), (10.0, 25.0), (30.0, 12.0), (100.0, 110.0), (7.5, 60.0)]:
    print(f"({a!r}, {x!r}, {float(sp.gammainc(a, x))!r}, {float(sp.gammaincc(a, x))!r}),")
print("// chi2: (x, k, cdf, sf)")
for x, k in [(3.84, 1), (18.3, 10), (31.41, 20), (5.0, 18), (120.0, 40), (250.0, 100)]:
    print(f"({x!r}, {k!r}.0, {float(st.chi2.cdf(x, k))!r}, {float(st.chi2.sf(x, k))!r}),")
print("// beta_inc: (a, b, x, I_x(a,b))")
for a, b, x in [(0.5, 0.5, 0.3), (2.0, 3.0, 0.4), (10.0, 0.5, 0.9), (0.5, 10.0, 0.01), (50.0, 40.0, 0.55), (1.0, 1.0, 0.77), (200.0, 0.5, 0.995)]:
    print(f"({a!r}, {b!r}, {x!r}, {float(sp.betainc(a, b, x))!r}),")
print("// t cdf: (t, nu, cdf)")
for t, nu in [(-2.0, 3.0), (0.5, 1.0), (1.5, 2.0), (-4.0, 10.0), (2.1, 30.0), (-7.5, 100.0), (3.0, 1e5), (-12.0, 5.0)]:
    print(f"({t!r}, {nu!r}, {float(st.t.cdf(t, nu))!r}),")
print("// t quantile: (p, nu, t)")
for p, nu in [(0.975, 1.0), (0.025, 2.0), (0.95, 5.0), (1e-6, 10.0), (0.999, 3.0), (1e-9, 35998.0), (0.3, 7.0), (0.05 / (2 * 2000), 1998.0), (1e-12, 4.0)]:
    print(f"({p!r}, {nu!r}, {float(st.t.ppf(p, nu))!r}),")
print("// normal: (x, cdf, sf)")
for x in [-37.0, -10.0, -3.0, -1.0, 0.0, 0.3, 1.96, 5.0, 8.5]:
    print(f"({x!r}, {float(st.norm.cdf(x))!r}, {float(st.norm.sf(x))!r}),")
print("// normal quantile: (p, x)")
for p in [1e-300, 1e-20, 1e-8, 0.001, 0.025, 0.2, 0.5, 0.7, 0.975, 0.999999]:
    print(f"({p!r}, {float(st.norm.ppf(p))!r}),")
print("// Huber consistency factor E[min(Z^2, c^2)], c = 2.5 (src/stage/gross_error.rs)")
from scipy import integrate
c = 2.5
print(repr(integrate.quad(lambda z: min(z * z, c * c) * st.norm.pdf(z), -40, 40, points=[-c, c], limit=200, epsabs=1e-14, epsrel=1e-14)[0]))
