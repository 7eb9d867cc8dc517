import csv, sys, math
# eval IN.csv OUT.csv axis: compare raw and out vs truth on the axis, during sway and after.
inp, outp, axis = sys.argv[1], sys.argv[2], sys.argv[3]
col = 'gx' if axis=='x' else 'gz'
R=list(csv.DictReader(open(inp))); O=list(csv.DictReader(open(outp)))
n=min(len(R),len(O)); dt=0.01
ar=ao=0; er2r=er2o=0; mr=mo=0; still=rep=moving=0
for i in range(n):
    tr=float(R[i]['true']); raw=float(R[i][col]); o=float(O[i][col])
    ar+=(raw-tr)*dt; ao+=(o-tr)*dt
    mr=max(mr,abs(ar)); mo=max(mo,abs(ao))
    er2r+=(raw-tr)**2; er2o+=(o-tr)**2
    fl=int(O[i]['flags']); still+=(fl>>14)&1; rep+=(fl>>15)&1
    moving+=((fl>>14)&1) and abs(tr)>math.radians(0.5)
d=180/math.pi
print('%-14s angle err end raw %7.2f out %7.2f | max raw %7.2f out %7.2f deg | rms raw %.4f out %.4f | still %d rep %d | still while moving %d' % (inp, ar*d, ao*d, mr*d, mo*d, math.sqrt(er2r/n)*d, math.sqrt(er2o/n)*d, still, rep, moving))
