#!/bin/bash
export XDG_RUNTIME_DIR=/tmp/xdg
cd /tmp/s19
for spec in "acmh" "acmm" "regions" "regions:--set prior_flat_ramp=false"; do
 m=${spec%%:*}; extra=""; [ "$spec" != "$m" ] && extra=${spec#*:}
 tag=$m; [ -n "$extra" ] && tag=$m-noramp
 for b in old new; do
  bin=/tmp/s18/mv-head; [ $b = new ] && bin=./mv-head
  [ $b = old ] && oextra="" || oextra="$extra"
  w=cl-$b-$tag; rm -rf $w
  nice $bin plan /tmp/s16/demo --out $w --tasks 2 --method $m $oextra > $w.log 2>&1
  n=$(python3 -c "import json;print(len(json.load(open('$w/plan.json'))['stages']))" 2>/dev/null || echo 0)
  for ((k=0;k<n;k++)); do for c in 0 1; do nice $bin task $w --stage $k --chunk $c >> $w.log 2>&1; done; done
  nice $bin task $w --fuse >> $w.log 2>&1
 done
 d=0; for f in $(cd cl-old-$tag && find . -name '*.pfm' -o -name fused.ply); do cmp -s cl-old-$tag/$f cl-new-$tag/$f || d=$((d+1)); done
 echo "$tag: stages $n, files $(cd cl-old-$tag && find . -name '*.pfm' -o -name fused.ply | wc -l), differ $d"
done
echo cldone
nice ./mv-head bench --accuracy /work/shared/data --scenes kitchen-a --max-image-size 320 --methods regions --json ka-ship.json > ka-ship.log 2>&1
echo kadone >> ka-ship.log
