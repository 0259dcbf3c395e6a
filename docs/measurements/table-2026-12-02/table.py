import json,sys,collections
MID="Adirondack,ArtL,Teddy,Aloe,Baby1,Bowling1,Dolls,Flowerpots,Lampshade1,Midd1,Wood1".split(",")
ROOMS=["icl-livingroom","kitchen-a","kitchen-b"]
def load(fs):
    out=collections.defaultdict(dict)
    for f in fs:
        for r in json.load(open(f)): out[r['method']][r['scene']]=r
    return out
def mean(rs,k):
    v=[r[k] for r in rs if r.get(k) is not None]; return sum(v)/len(v)*100
def cloud(r,t,k):
    for c in r.get('cloud',[]):
        if abs(c['threshold']-t)<1e-9: return c[k]
    return float('nan')
for label,fs in [(a.split('=')[0],a.split('=')[1].split(',')) for a in sys.argv[1:]]:
    d=load(fs)
    print("##",label)
    for m,sc in d.items():
        mid=[sc[s] for s in MID if s in sc]
        if len(mid)==11:
            print(f"{m:7s} Middlebury(11) w1 {mean(mid,'within_1'):.1f} w2 {mean(mid,'within_2'):.1f} weak {mean(mid,'low_texture_within_2'):.1f}  s {sum(r['seconds'] for r in mid):.0f}")
        for s in sc:
            if s.startswith('synthetic'):
                r=sc[s]; print(f"{m:7s} {s} w1 {r['within_1']*100:.1f} w2 {r['within_2']*100:.1f} weak {r['low_texture_within_2']*100:.1f}")
        rooms=[sc[s] for s in ROOMS if s in sc]
        if len(rooms)==3:
            print(f"{m:7s} rooms(3) w2 {mean(rooms,'within_2'):.1f} w5 {mean(rooms,'within_5'):.1f} weak {mean(rooms,'low_texture_within_2'):.1f} F1@2 {sum(cloud(r,0.02,'f1') for r in rooms)/3*100:.1f} F1@5 {sum(cloud(r,0.05,'f1') for r in rooms)/3*100:.1f} s {sum(r['seconds'] for r in rooms):.0f}")
            for r in rooms: print(f"      {r['scene']:14s} w1 {r['within_1']*100:.1f} w2 {r['within_2']*100:.1f} ({r['low_texture_within_2']*100:.1f}) w5 {r['within_5']*100:.1f}")
