OLD=/tmp/ci44/main/target/debug/mvscope
NEW=/work/main/target/debug/mvscope
export XDG_RUNTIME_DIR=/tmp/xdg
cmpdir() { local bad=0 n=0
  for f in $(cd $1 && find depth normal cost confidence -type f | sort) fused.ply; do n=$((n+1)); cmp -s $1/$f $2/$f || { echo "DIFF $f"; bad=1; }; done
  echo "$3: $n files, $([ $bad = 0 ] && echo identical || echo DIFFERENT)"; }
for m in acmp acmmp regions; do
  rm -rf B-OLD-$m B-NEW-$m
  $OLD run demo --out B-OLD-$m --method $m --device-memory 1.4 >/dev/null 2>&1
  $NEW run demo --out B-NEW-$m --method $m --device-memory 1.4 >/dev/null 2>&1
  cmpdir B-OLD-$m B-NEW-$m "$m budget 1.4 MiB ($(grep -o '"batches": [0-9]*' B-NEW-$m/report.json))"
  cmpdir NEW-$m B-NEW-$m "$m budget vs whole (new)"
done
