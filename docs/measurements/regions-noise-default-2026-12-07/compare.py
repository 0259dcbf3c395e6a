# Prints the suite table of docs/accuracy.md "Regions under sensor noise, by default" from
# three bench --accuracy JSON files: the previous defaults, the two options without the join
# count, and the new defaults. Usage: compare.py OLD.json UNGATED.json NEW.json
import json, sys
rows = [{r["scene"]: r for r in json.load(open(f))} for f in sys.argv[1:4]]
def cell(r):
    w = r.get("low_texture_within_2")
    return f"{100 * r['within_1']:.1f} / {100 * r['within_2']:.1f}" + (f" ({100 * w:.1f})" if w is not None else "")
def mean(rs, key):
    v = [r[key] for r in rs if r.get(key) is not None]
    return sum(v) / len(v) if v else None
mid = ["Adirondack", "ArtL", "Teddy", "Aloe", "Baby1", "Bowling1", "Dolls", "Flowerpots", "Lampshade1", "Midd1", "Wood1"]
rooms = ["icl-livingroom", "kitchen-a", "kitchen-b"]
print("| scene | previous defaults | both options, no join count | new defaults |")
print("|---|---|---|---|")
for name in mid + rooms + ["synthetic-320x240", "synthetic-room-320x240"]:
    if all(name in r for r in rows):
        print(f"| {name} | " + " | ".join(cell(r[name]) for r in rows) + " |")
for label, group in (("mean of 11 Middlebury pairs", mid), ("mean of 3 rooms", rooms)):
    out = []
    for r in rows:
        rs = [r[n] for n in group if n in r]
        m1, m2, w = mean(rs, "within_1"), mean(rs, "within_2"), mean(rs, "low_texture_within_2")
        out.append(f"{100 * m1:.1f} / {100 * m2:.1f} ({100 * w:.1f})")
    print(f"| {label} | " + " | ".join(out) + " |")
r5 = []
for r in rows:
    rs = [r[n] for n in rooms if n in r]
    r5.append(f"{100 * mean(rs, 'within_5'):.1f}")
print("| 3 rooms within 5% | " + " | ".join(r5) + " |")
