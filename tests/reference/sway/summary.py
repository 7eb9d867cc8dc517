import re, sys
# summary.py RESULTS.txt: the grid's aggregate (docs/real-data.md, "A sway is neither rest nor bias").
rows = []
for line in open(sys.argv[1]):
    m = re.search(r'angle err end raw\s+(-?[\d.]+) out\s+(-?[\d.]+) .* rms raw ([\d.]+) out ([\d.]+) .* still while moving (\d+)', line)
    rows.append((line.split()[:4], abs(float(m.group(2))), float(m.group(4)), int(m.group(5))))
ends = sorted(r[1] for r in rows)
print('%d benches: output RMS above 0.30 deg/s: %d (largest %.4f); STILL while |rate| > 0.5 deg/s: %d'
      % (len(rows), sum(r[2] > 0.30 for r in rows), max(r[2] for r in rows), sum(r[3] for r in rows)))
print('|angle error at the end|: mean %.2f, median %.2f, largest %.2f deg; above 5 deg: %d'
      % (sum(ends) / len(ends), ends[len(ends) // 2], ends[-1], sum(e > 5 for e in ends)))
for r in sorted(rows, key=lambda r: -r[1])[:6]:
    print('  %s deg/s, %s s, %s, seed %s: %.2f deg' % (*r[0], r[1]))
