import pickle, numpy as np, sys
for tag in ["off", "on"]:
    try: out = pickle.load(open(f"/tmp/s47/ana/cells2-2-{tag}.pkl", "rb"))
    except FileNotFoundError: continue
    ch = []; nflat = []; best_right = []; flat_right = []; rho = []; rank_right = []
    for o in out:
        c = o["candidates"]
        chosen = next((p for p in c if o["chosen"] is not None and tuple(p["pixel"]) == tuple(o["chosen"])), None)
        ch.append(chosen)
        flat = [p for p in c if p["flat"]]
        nflat.append(len(flat))
        elig = [p for p in c if p["eligibility"] in ("below cost limit", "flat window")]
        if elig:
            flat_right.append(np.mean([abs(p["err"]) < 0.02 for p in elig]))
            best_right.append(any(abs(p["err"]) < 0.02 for p in elig))
            sc = np.array([p["score"] for p in elig]); e = np.array([abs(p["err"]) for p in elig])
            if len(elig) > 3 and sc.std() > 0: rho.append(np.corrcoef(np.argsort(np.argsort(sc)), np.argsort(np.argsort(e)))[0, 1])
    e = np.array([abs(p["err"]) if p else np.nan for p in ch]); se = np.array([p["err"] if p else np.nan for p in ch])
    conf = np.array([p["confidence"] if p else np.nan for p in ch]); cost = np.array([p["cost"] if p else np.nan for p in ch])
    print(f"{tag}: cells {len(out)}, chosen {np.sum(~np.isnan(e))}; chosen within 1% {np.nanmean(e<0.01):.2f}, 2% {np.nanmean(e<0.02):.2f}, median signed err {np.nanmedian(se):+.4f}")
    print(f"   eligible candidates per cell {np.mean([sum(p['eligibility'] in ('below cost limit','flat window') for p in o['candidates']) for o in out]):.1f}, flat {np.mean(nflat):.1f}; share of eligible within 2% {np.mean(flat_right):.2f}; cells with some eligible within 2% {np.mean(best_right):.2f}")
    print(f"   chosen: cost median {np.nanmedian(cost):.3f}, confidence median {np.nanmedian(conf):.3f}; rank correlation score vs |err| among eligible (per cell, mean) {np.mean(rho):+.2f}")
    print("   eligibility of chosen:", {k: sum(1 for p in ch if p and p['eligibility'] == k) for k in set(p['eligibility'] for p in ch if p)})
    print("   chosen confidence values:", np.unique(np.round(conf[~np.isnan(conf)], 3), return_counts=True))
    if tag == "off": print("   keys example", out[0]["candidates"][0])
