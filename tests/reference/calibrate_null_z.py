"""The null distribution of the calibration's held-out paired z for a superfluous group, with a
perfect noise model: what `imuprep calibrate`'s round-1 z on clean tumbles should look like.

A linear model y = J θ + n, n white with unit variance, 25 motions of 2 components, 9 parameters
(J random normal), q of them a superfluous group (truth 0). Each motion is left out in turn; its
held-out residual is e_k = (I − H_kk)⁻¹ r_k (r the full fit's residuals, H the hat matrix: the
exact leave-one-block-out identity of least squares). z as `diagnose_blocks::held_out_test`:
z = (Σe0² − Σe1²) / (2 σ̂ √Σ(e0 − e1)²), σ̂² = mean e1², e1 with the group, e0 without it.
`--refit` whitens each held-out block with its own covariance (I − H_kk)⁻¹ (the refit's error
included), as `calib_gyro_noise::HeldOutWhitener` does. Prints the mean, sd, largest z, the
tail probabilities, and the spread of the sd of 20 and of 40 draws (what 20 or 40 seeds give).

    python3 tests/reference/calibrate_null_z.py 3 10000 7            # q = 3 (scale), seed 7
    python3 tests/reference/calibrate_null_z.py 6 10000 8 --refit    # q = 6 (misalignment)

Pure Python (no numpy); 10 000 draws ≈ 1 min.
"""

import random
import statistics
import sys

N_MOTIONS, N_PARAMS = 25, 9


def inverse(a):
    n = len(a)
    m = [row[:] + [float(i == j) for j in range(n)] for i, row in enumerate(a)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        d = m[c][c]
        m[c] = [x / d for x in m[c]]
        for r in range(n):
            if r != c and m[r][c] != 0.0:
                f = m[r][c]
                m[r] = [x - f * y for x, y in zip(m[r], m[c])]
    return [row[n:] for row in m]


def held_out(j, y, cols):
    """Per motion: the held-out residual (2) and the block (I − H_kk)."""
    jc = [[row[c] for c in cols] for row in j]
    p, n = len(cols), len(y)
    info = inverse([[sum(jc[i][a] * jc[i][b] for i in range(n)) for b in range(p)] for a in range(p)])
    jty = [sum(jc[i][b] * y[i] for i in range(n)) for b in range(p)]
    th = [sum(info[a][b] * jty[b] for b in range(p)) for a in range(p)]
    r = [y[i] - sum(jc[i][a] * th[a] for a in range(p)) for i in range(n)]
    out = []
    for k in range(n // 2):
        rows = (2 * k, 2 * k + 1)
        h = [[sum(jc[i][a] * info[a][b] * jc[l][b] for a in range(p) for b in range(p)) for l in rows] for i in rows]
        ih = [[float(i == l) - h[i][l] for l in range(2)] for i in range(2)]
        m = inverse(ih)
        out.append(([m[i][0] * r[2 * k] + m[i][1] * r[2 * k + 1] for i in range(2)], ih))
    return out


def main():
    q, reps, seed = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
    refit = "--refit" in sys.argv
    rng = random.Random(seed)
    zs = []
    for _ in range(reps):
        j = [[rng.gauss(0, 1) for _ in range(N_PARAMS)] for _ in range(2 * N_MOTIONS)]
        y = [rng.gauss(0, 1) for _ in range(2 * N_MOTIONS)]
        with_g = held_out(j, y, list(range(N_PARAMS)))
        without = held_out(j, y, list(range(q, N_PARAMS)))
        e1, e0 = [], []
        for (a, ih), (b, _) in zip(with_g, without):
            if refit:
                # W with W (I − H)⁻¹ Wᵀ = I: W = Lᵀ, L Lᵀ = I − H_kk.
                l11 = ih[0][0] ** 0.5
                l21 = ih[1][0] / l11
                l22 = (ih[1][1] - l21 * l21) ** 0.5
                w = ((l11, l21), (0.0, l22))
                a = [w[i][0] * a[0] + w[i][1] * a[1] for i in range(2)]
                b = [w[i][0] * b[0] + w[i][1] * b[1] for i in range(2)]
            e1 += a
            e0 += b
        s1, s0 = sum(x * x for x in e1), sum(x * x for x in e0)
        dd = sum((a - b) ** 2 for a, b in zip(e0, e1))
        zs.append((s0 - s1) / (2.0 * (s1 / len(e1) * dd) ** 0.5))
    print(
        f"q = {q}{' (refit-whitened)' if refit else ''}: z mean {statistics.mean(zs):.2f}"
        f" sd {statistics.stdev(zs):.2f} largest {max(zs):.2f} over {reps};"
        f" P(z > 2.33) = {sum(z > 2.33 for z in zs) / reps:.4f}, P(z > 3.09) = {sum(z > 3.09 for z in zs) / reps:.4f}"
    )
    for n in (20, 40):
        sds = sorted(statistics.stdev(zs[i : i + n]) for i in range(0, reps - n + 1, n))
        pick = lambda f: sds[min(len(sds) - 1, int(f * len(sds)))]
        print(
            f"  sd of {n} z: 1% {pick(0.01):.2f}, 5% {pick(0.05):.2f}, median {pick(0.5):.2f},"
            f" 95% {pick(0.95):.2f}, 99% {pick(0.99):.2f} ({len(sds)} sets)"
        )


if __name__ == "__main__":
    main()
