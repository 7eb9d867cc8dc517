"""statsmodels' Burg and Yule-Walker on the series of `benches/ar_fit.rs`, timed, and their
coefficients (pasted into tests/ar_reference_checks.rs, `bench_series_*`).

The series is generated bit-identically to the bench: xoshiro256** seeded through splitmix64
(src/rng.rs), uniform = (next >> 11) * 2**-53, then
v[n] = 1.5 v[n-1] - 0.7 v[n-2] + (2u - 1), x[n] = 0.05 + v[n] + 0.5 (2u' - 1).
Run from the crate root right after `cargo bench --bench ar_fit`, on the same machine:
    python3 tests/reference/ar_fit_timing.py
Medians over REPEATS calls of wall time (time.perf_counter) and of the thread's CPU time
(time.thread_time), as the bench reports medians of both.
Versions used: statsmodels 0.15.0, numpy 2.4.6.
BLAS is limited to one thread (imuprep's fits are single-threaded; on a shared 2-core machine a
multi-threaded BLAS dot spins and measures the load, not the method).
numpy allocates a fresh 2.9 MB temporary for every array expression; on this machine returning
those to the kernel and faulting them back in costs more than the arithmetic (statsmodels' Burg
p=10 takes ~170 ms here with default malloc settings), so the script re-executes itself with
glibc's mmap / trim thresholds raised, which keeps the temporaries on the heap: statsmodels'
best case here.
"""
import os
import sys

_ENV = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "MALLOC_MMAP_THRESHOLD_": "4294967296",
    "MALLOC_TRIM_THRESHOLD_": "4294967296",
}
if any(os.environ.get(k) != v for k, v in _ENV.items()):
    os.execve(sys.executable, [sys.executable] + sys.argv, {**os.environ, **_ENV})

import statistics
import time
import warnings

import numpy as np
import statsmodels
from statsmodels.regression.linear_model import burg, yule_walker

M64 = (1 << 64) - 1


def splitmix64(state):
    state = (state + 0x9E3779B97F4A7C15) & M64
    z = state
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    return state, z ^ (z >> 31)


def rotl(x, k):
    return ((x << k) | (x >> (64 - k))) & M64


class Rng:
    def __init__(self, seed):
        x = seed
        s = []
        for _ in range(4):
            x, z = splitmix64(x)
            s.append(z)
        self.s = s

    def next_u64(self):
        s = self.s
        result = (rotl((s[1] * 5) & M64, 7) * 9) & M64
        t = (s[1] << 17) & M64
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = rotl(s[3], 45)
        return result

    def uniform(self):
        return (self.next_u64() >> 11) * (1.0 / (1 << 53))


def series(n):
    rng = Rng(20261124)
    a = b = 0.0
    out = np.empty(n)
    for i in range(n):
        v = 1.5 * a - 0.7 * b + (2.0 * rng.uniform() - 1.0)
        b = a
        a = v
        out[i] = 0.05 + v + 0.5 * (2.0 * rng.uniform() - 1.0)
    return out


def median_time(f, repeats):
    """Medians of wall time and of this thread's CPU time, s."""
    f()  # warm-up
    wall, cpu = [], []
    for _ in range(repeats):
        c0 = time.thread_time()
        t0 = time.perf_counter()
        f()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
    return statistics.median(wall), statistics.median(cpu)


def main():
    n = 360_000
    x = series(n)
    # same left-to-right sum as the bench's `iter().sum()`
    s = 0.0
    for v in x:
        s += v
    print(f"series: n = {n}, sum = {s:.17e}, x[0] = {x[0]:.17e}, x[N-1] = {x[-1]:.17e}")
    print(f"statsmodels {statsmodels.__version__}, numpy {np.__version__}, python {sys.version.split()[0]}")
    np.set_printoptions(precision=17)
    for p in (10, 20):
        rho, s2 = burg(x, order=p, demean=True)
        print(f"burg p={p} coeffs={list(map(float, rho))} noise_var={float(s2)!r}")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rho, sig = yule_walker(x, order=p, method="mle", result_object=False)
        print(f"yule_walker p={p} coeffs={list(map(float, rho))} noise_var={float(sig**2)!r}")
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    for p in (10, 20):
        tb = median_time(lambda: burg(x, order=p, demean=True), repeats)
        ty = median_time(
            lambda: yule_walker(x, order=p, method="mle", result_object=False), repeats
        )
        print(f"statsmodels burg p={p}: median wall {tb[0] * 1e3:.3f} ms, thread CPU {tb[1] * 1e3:.3f} ms")
        print(f"statsmodels yule_walker p={p}: median wall {ty[0] * 1e3:.3f} ms, thread CPU {ty[1] * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
