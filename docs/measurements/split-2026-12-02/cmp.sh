#!/usr/bin/env bash
# Byte-for-byte: every method, old vs new binary, resident / batched / cluster chain.
set -u
OLD=/tmp/old-mvscope; NEW=/tmp/new-mvscope
SCENE=${SCENE:-/work/shared/data/rgbd/icl-livingroom}
SZ=${SZ:-160}
W=/tmp/s33/cmp; rm -rf $W; mkdir -p $W
export XDG_RUNTIME_DIR=/tmp/xdg-runtime-0
for m in ${METHODS:-dwta acmh acmm acmp acmmp regions}; do
  for b in old new; do
    B=$OLD; [ $b = new ] && B=$NEW
    $B run $SCENE --method $m --seed 0 --max-image-size $SZ --out $W/$m-$b-res >/dev/null 2>$W/$m-$b-res.err || echo "FAIL $m $b res"
    $B run $SCENE --method $m --seed 0 --max-image-size $SZ --device-memory 3 --host-memory 0.001 --out $W/$m-$b-bat >$W/$m-$b-bat.log 2>&1 || echo "FAIL $m $b bat"
  done
  # cluster chain with the new binary
  $NEW plan $SCENE --method $m --seed 0 --max-image-size $SZ --out $W/$m-new-clu --tasks 2 >/dev/null 2>&1 || echo "FAIL plan $m"
  n=$(python3 -c "import json;print(len(json.load(open('$W/$m-new-clu/plan.json'))['stages']))" 2>/dev/null || echo 0)
  for k in $(seq 0 $((n-1))); do for c in 0 1; do $NEW task $W/$m-new-clu --stage $k --chunk $c >/dev/null 2>&1 || echo "FAIL task $m $k $c"; done; done
  $NEW task $W/$m-new-clu --fuse >/dev/null 2>&1 || echo "FAIL fuse $m"
  for v in new-res old-bat new-bat new-clu; do
    d=0; cnt=0
    for f in $(cd $W/$m-old-res && find . -name '*.pfm' -o -name '*.ply' | sort); do
      cnt=$((cnt+1)); cmp -s $W/$m-old-res/$f $W/$m-$v/$f || { d=$((d+1)); echo "  differs: $m $v $f"; }
    done
    echo "$m old-res vs $v: $cnt files, $d differ"
  done
  grep -o "batch[^,]*" $W/$m-new-bat.log | head -1
done
