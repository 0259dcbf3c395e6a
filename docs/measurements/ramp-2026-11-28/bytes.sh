#!/bin/bash
export XDG_RUNTIME_DIR=/tmp/xdg
cd /tmp/s19/b
for m in dwta acmh acmm acmp acmmp regions; do
  rm -rf old-$m new-$m bat-$m
  nice /tmp/s18/mv-head run /tmp/s16/demo --method $m --out old-$m > old-$m.log 2>&1
  nice ./mv-new run /tmp/s16/demo --method $m --out new-$m > new-$m.log 2>&1
  nice ./mv-new run /tmp/s16/demo --method $m --device-memory 4 --out bat-$m > bat-$m.log 2>&1
  n=0; w=0
  for d in depth normal cost confidence; do for f in old-$m/$d/*; do cmp -s $f new-$m/$d/$(basename $f) || n=$((n+1)); cmp -s new-$m/$d/$(basename $f) bat-$m/$d/$(basename $f) || w=$((w+1)); done; done
  cmp -s old-$m/fused.ply new-$m/fused.ply || n=$((n+1))
  cmp -s new-$m/fused.ply bat-$m/fused.ply || w=$((w+1))
  echo "$m: old-vs-new differ $n, whole-vs-batched differ $w"
done
echo bdone
rm -rf noramp; nice ./mv-new run /tmp/s16/demo --method regions --set prior_flat_ramp=false --out noramp > noramp.log 2>&1
n=0; for d in depth normal cost confidence; do for f in old-regions/$d/*; do cmp -s $f noramp/$d/$(basename $f) || n=$((n+1)); done; done
cmp -s old-regions/fused.ply noramp/fused.ply || n=$((n+1))
echo "regions without the ramp vs old regions differ $n"
