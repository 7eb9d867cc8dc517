"""Reference values for bias_state_space::tests::innovation_variance_matches_scipy_dare.

Steady-state one-step innovation variance H P H' + R of the Kalman filter for
b = AR(p) in companion form (driving variance q) observed in white noise of variance R,
from scipy.linalg.solve_discrete_are (the filtering DARE is the dual of the control DARE:
solve_discrete_are(F', H', Q, R)). Run: python3 tests/reference/innovation_var.py
"""
import numpy as np
from scipy.linalg import solve_discrete_are

CASES = [
    ([1.5, -0.56], 1e-4, 1.0),
    ([0.999], 1e-6, 3e-6),
    ([1.6, -0.64], 4e-8, 3.0e-6),
]

for i, (phi, q, r) in enumerate(CASES):
    p = len(phi)
    F = np.zeros((p, p))
    F[0, :] = phi
    F[1:, :-1] += np.eye(p - 1) if p > 1 else 0.0
    H = np.zeros((1, p)); H[0, 0] = 1.0
    Q = np.zeros((p, p)); Q[0, 0] = q
    P = solve_discrete_are(F.T, H.T, Q, np.array([[r]]))
    s = (H @ P @ H.T)[0, 0] + r
    print(f"const SCIPY_CASE{i}: f64 = {float(s)!r};")
