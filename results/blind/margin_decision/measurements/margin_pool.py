import json, sys, glob, time, numpy as np
sys.path.insert(0,'.')
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.blind import trapezoid_critical
field=DriveField.load('results/recipe/teacher_field.npz')
P=[];B=[]
for f in sorted(glob.glob('results/blind/*/blind.json')):
    r=json.load(open(f))
    if 'best' not in r: continue
    P+=[(float(k),float(m)) for k,m in r['points']]; B+=[b['velocity'] for b in r['best']]
B=np.array(B); sc=B>=2e-3
for m in [0.0, 0.06]:
    t0=time.time(); _,t=field.best(P,radius=2,load_margin=m); dt=time.time()-t0
    f=t[sc]/B[sc]
    print(f"margin {m}: {dt:.1f}s  mean {f.mean():.4f} min {f.min():.3f} under.85 {(f<.85).sum()} under.9 {(f<.9).sum()} under.95 {(f<.95).sum()}")
