#!/bin/bash
# Device accuracy run (fourteenth session). Usage: bash .dev/gpu.sh OUTDIR [extra bench args for a local dry run]
O=$1; shift; X="$*"
exec > >(tee $O/log.txt) 2>&1
set -x
if [ -d .gl ] && [ -n "$DEVICE" ]; then for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig; fi
mkdir -p /work/shared/data /tmp/x
[ -d /work/shared/data/rgbd ] || tar xJf .dev/data.tar.xz -C /work/shared/data
tar xJf .dev/extra.tar.xz -C /tmp/x
M=/tmp/x/mvscope; xz -dc .dev/mvscope.xz > $M; chmod +x $M
nvidia-smi -L 2>/dev/null; date
B="$M bench --accuracy"
D=/work/shared/data
t() { local s=$(date +%s); "$@"; echo "TIME $(( $(date +%s) - s )) s: $*"; }
t $B $D --seeds 0,1 --json $O/a-full.json $X
t $B /tmp/x/s10/reg --scenes icl-livingroom --seeds 0,1 --json $O/b-reg.json $X
t $B /tmp/x/s11/k526 --scenes kitchen --methods acmh,acmm,acmmp,regions --seeds 0,1 --json $O/c-k526.json $X
t $B $D --methods regions --set prior_hold_regions_only=true --seeds 0,1 --json $O/d-regonly.json $X
t $B /tmp/x/s10/reg --scenes icl-livingroom --methods regions --set prior_hold_regions_only=true --seeds 0,1 --json $O/e-regonly-reg.json $X
t $B $D --scenes icl,kitchen --methods acmm,acmmp,regions --set scales_by_texture=true --seeds 0,1 --json $O/f-sbt.json $X
t $B /tmp/x/s10/reg --scenes icl-livingroom --methods acmm,acmmp,regions --set scales_by_texture=true --seeds 0,1 --json $O/g-sbt-reg.json $X
date
