# Regions' new defaults: its maps and cloud whole, in batches under a device budget, and as a
# cluster chain, compared byte for byte (the noise estimate and the band run on the host per
# view and level, so every schedule must give the same maps).
set -u
NEW=/work/main/target/release/mvscope
export XDG_RUNTIME_DIR=/tmp/xdg
mkdir -p /tmp/s49/cmp && cd /tmp/s49/cmp
$NEW demo --out demo --width 96 --height 72 --views 5 >/dev/null 2>&1
cmpdir() {
  local bad=0 n=0
  for f in $(cd $1 && find depth normal cost confidence -type f | sort) fused.ply; do
    n=$((n+1)); cmp -s $1/$f $2/$f || { echo "DIFF $1/$f"; bad=1; }
  done
  echo "$3: $n files, $([ $bad = 0 ] && echo identical || echo DIFFERENT)"
}
m=regions
$NEW run demo --out $m --method $m >/dev/null 2>&1 || echo "run failed"
grep -E "prior_flat_noise|prior_region_cover_band" $m/params.toml
$NEW run demo --out $m-budget --method $m --device-memory 1.4 >/dev/null 2>&1 || echo "budget run failed"
cmpdir $m $m-budget "$m budget 1.4 MiB ($(grep -o '"batches": [0-9]*' $m-budget/report.json | head -1))"
$NEW plan demo --out $m-chain --method $m --tasks 2 >/dev/null 2>&1
k=$(python3 -c "import json;print(len(json.load(open('$m-chain/plan.json'))['stages']))")
for s in $(seq 0 $((k-1))); do for c in 0 1; do $NEW task $m-chain --stage $s --chunk $c >/dev/null 2>&1 || echo "task failed $s $c"; done; done
$NEW task $m-chain --fuse >/dev/null 2>&1
grep -E "prior_flat_noise|prior_region_cover_band" $m-chain/params.toml
cmpdir $m $m-chain "$m cluster chain vs whole"
$NEW run demo --out $m-off --method $m --set prior_flat_noise=false --set prior_region_cover_band=0 >/dev/null 2>&1
cmpdir $m $m-off "$m vs $m with both options off (expected to differ)"
