import math, random, sys
# sway: rest0 90 s, then sinusoidal rate A dps period P s about AXIS (x or z) for HOLD s, then rest 90 s.
# args OUT A_dps P_s HOLD_s axis seed
out, A, P, hold, axis, seed = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), sys.argv[5], int(sys.argv[6])
random.seed(seed)
fs=100.0; rest0=90.0; rest1=90.0; T=rest0+hold+rest1; g=9.80665
w=A*math.pi/180; th=0.0
bias=[0.01,-0.02,0.005]
with open(out,'w') as f:
    f.write('t,gx,gy,gz,ax,ay,az,true\n')
    for i in range(int(T*fs)):
        t=i/fs
        r = w*math.sin(2*math.pi*(t-rest0)/P) if rest0<=t<rest0+hold else 0.0
        th += r/fs
        tr=[0,0,0]; k=0 if axis=='x' else 2; tr[k]=r
        gy=[tr[j]+bias[j]+0.005*random.gauss(0,1) for j in range(3)]
        if axis=='x':
            a=[0.1, g*math.sin(th)-0.2, g*math.cos(th)]
        else:
            a=[0.1,-0.2,g]
        a=[a[j]+0.03*random.gauss(0,1) for j in range(3)]
        f.write('%.4f,%.7f,%.7f,%.7f,%.6f,%.6f,%.6f,%.7f\n'%(t,*gy,*a,r))
