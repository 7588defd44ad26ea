import json, sys, numpy as np
sys.path.insert(0,'.')
from mdr_drive_agents.drive_field import DriveField
from mdr_drive_agents.evaluate import critical_loads_grid
field=DriveField.load('results/recipe/teacher_field.npz')
out={}
for f in ['results/blind/seed20261123/blind.json','results/blind/seed20261133/blind.json']:
    c=json.load(open(f))['critical_load_kg']
    for m in (0.0, 0.06):
        ct=critical_loads_grid(c['k'], lambda pts: field.best(pts, radius=2, load_margin=m)[1])
        r=np.array([ct[k] for k in c['k']])/np.array(c['best cycle'])
        print(f, m, 'min', r.min().round(3), 'at', c['k'][int(r.argmin())], '>=.97:', (r>=.97).sum(), 'of', len(r), '>=.99:', (r>=.99).sum())
