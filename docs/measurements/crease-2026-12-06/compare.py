"""Regions before and after a rule (the slice rule, then the crease rule), scene by scene, from two `bench --accuracy
--json` files (and optional extra pairs): within 1% / 2% / 5%, weak texture within 2%, and
the cloud's F1 at 2 and 5 cm where a scene has one.

    python3 compare.py BEFORE.json AFTER.json [BEFORE2.json AFTER2.json ...]
"""
import json
import sys


def rows(path):
    return {r["scene"]: r for r in json.load(open(path))}


def pct(v):
    return "-" if v is None else f"{100 * v:.1f}"


def f1(r, k):
    c = r.get("cloud") or []
    return c[k]["f1"] if len(c) > k else None


pairs = list(zip(sys.argv[1::2], sys.argv[2::2]))
print("| scene | within 1% | within 2% | within 5% | weak within 2% | F1 2 / 5 cm |")
print("|---|---|---|---|---|---|")
mid = []
for before_path, after_path in pairs:
    before, after = rows(before_path), rows(after_path)
    for name, a in after.items():
        b = before.get(name)
        if b is None:
            continue
        cells = []
        for key in ["within_1", "within_2", "within_5", "low_texture_within_2"]:
            cells.append(f"{pct(b[key])} → {pct(a[key])}")
        cells.append(
            f"{pct(f1(b, 0))} / {pct(f1(b, 1))} → {pct(f1(a, 0))} / {pct(f1(a, 1))}"
            if f1(a, 0) is not None
            else "-"
        )
        print(f"| {name} | " + " | ".join(cells) + " |")
        if b["low_texture_within_2"] is not None or name in ("Adirondack", "ArtL", "Teddy"):
            if not name.startswith(("icl", "kitchen", "synthetic")):
                mid.append((b, a))
if mid:
    n = len(mid)
    m2 = (sum(b["within_2"] for b, _ in mid) / n, sum(a["within_2"] for _, a in mid) / n)
    weak = [(b, a) for b, a in mid if b["low_texture_within_2"] is not None]
    mw = (
        sum(b["low_texture_within_2"] for b, _ in weak) / len(weak),
        sum(a["low_texture_within_2"] for _, a in weak) / len(weak),
    )
    print(
        f"| mean of {n} Middlebury pairs | | {pct(m2[0])} → {pct(m2[1])} | | "
        f"{pct(mw[0])} → {pct(mw[1])} ({len(weak)} with a mask) | |"
    )
