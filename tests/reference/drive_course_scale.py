"""Cross-check of `imuprep calibrate LOG --gnss POS` on the rtklibexplorer drive, written
independently in numpy: the gyro's rate about the vertical (here from the first 8 s at rest,
not from the mean specific force as imuprep takes it) integrated between straight moments
(speed > 4 m/s, |rate| < 1 deg/s over 9 epochs) against the RTK course change; OLS of the course
change on (-integral, -dt). Prints k = 1/(1 + s) with its sigma, the scale error and the bias.

    python3 tests/reference/drive_course_scale.py
    (measured: k = 0.99974 +- 0.00041, scale error +0.03 % +- 0.04, 76 segments;
     imuprep: -0.0015 % +- 0.0497 %, 77 segments)
"""
import numpy as np, datetime as dt, calendar
D='/work/shared/data/real/rtklibexplorer_drive_walk/'
imu=np.genfromtxt(D+'drive_0708_imu.csv',delimiter=',',names=True)
t=imu['gpst_s']; g=np.radians(np.c_[imu['gyro_x_dps'],imu['gyro_y_dps'],imu['gyro_z_dps']]); a=np.c_[imu['acc_x_g'],imu['acc_y_g'],imu['acc_z_g']]
P=[]
for line in open(D+'drive_0708_gnss_rtk.pos'):
    if line.startswith('%'): continue
    f=line.split()
    ts=calendar.timegm(dt.datetime.strptime(f[0]+' '+f[1][:8],'%Y/%m/%d %H:%M:%S').timetuple())+float('0'+f[1][8:])
    P.append((ts,int(float(f[5])),float(f[15]),float(f[16])))
P=np.array(P); tp=P[:,0]; q=P[:,1]; vn=P[:,2]; ve=P[:,3]
print('imu',t[0],t[-1],'pos',tp[0],tp[-1],'Q hist',np.unique(q,return_counts=True))
sp=np.hypot(vn,ve); psi=np.unwrap(np.arctan2(ve,vn))
# vertical from the first 10 s still
still=t<t[0]+8
up=a[still].mean(0); up/=np.linalg.norm(up)
print('up',up, 'gyro bias at start deg/s', np.degrees(g[still].mean(0)))
wv=g@up  # rate about up axis (right-handed)
# cumulative integral
cum=np.concatenate([[0],np.cumsum(0.5*(wv[1:]+wv[:-1])*np.diff(t))])
I=np.interp(tp,t,cum)
wr=np.interp(tp,t,wv)
# straight moments: speed>4, |rate| small over +-1 s
ok=(sp>4)&(q==1)
rate_s=np.abs(np.convolve(np.degrees(wr),np.ones(9)/9,'same'))
straight=ok&(rate_s<1.0)
idx=np.where(straight)[0]
# pick anchor points at least 3 s apart, then pair consecutive anchors within same continuous ok stretch
anch=[]
for i in idx:
    if not anch or tp[i]-tp[anch[-1]]>=3: anch.append(i)
rows=[]
for i,j in zip(anch[:-1],anch[1:]):
    if not ok[i:j+1].all(): continue
    dpsi=psi[j]-psi[i]; dI=I[j]-I[i]; dT=tp[j]-tp[i]
    rows.append((dpsi,dI,dT))
R=np.array(rows); print('segments',len(R),'with |dpsi|>20deg',(np.abs(np.degrees(R[:,0]))>20).sum())
# heading (clockwise from north) change = -(rotation about up)
y=R[:,0]; X=np.c_[-R[:,1],-R[:,2]]  # dpsi = k*(-dI) + (-b)*dT  => model dpsi = k*(-∫w) - b dT
beta,res,rk,sv=np.linalg.lstsq(X,y,rcond=None)
r=y-X@beta; s2=r@r/(len(y)-2); cov=s2*np.linalg.inv(X.T@X)
print('k=%.5f ± %.5f  (scale error %+.2f %% ± %.2f)  bias %.4f ± %.4f deg/s  resid sd %.3f deg'%(beta[0],np.sqrt(cov[0,0]),100*(1/beta[0]-1),100*np.sqrt(cov[0,0]),np.degrees(beta[1]),np.degrees(np.sqrt(cov[1,1])),np.degrees(np.sqrt(s2))))
