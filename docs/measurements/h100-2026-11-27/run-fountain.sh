#!/bin/bash
# Device run 2 (fourteenth session): Fountain-P11 resident and in batches, and memory flat in views.
O=$1; shift; X="$*"
exec > >(tee $O/log.txt) 2>&1
set -x
if [ -d .gl ] && [ -n "$DEVICE" ]; then for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig; fi
mkdir -p /tmp/y; M=/tmp/y/mvscope; xz -dc .dev2/mvscope.xz > $M; chmod +x $M
F=.dev2/fountain
t() { local s=$(date +%s); "$@"; echo "TIME $(( $(date +%s) - s )) s: $*"; }
t timeout 150 $M bench --scene $F --methods acmm,regions --json $O/a-fountain.json $X
t timeout 100 $M bench --scene $F --methods acmm --device-memory 2048 --json $O/b-fountain-2048.json $X
t timeout 100 $M bench --scale 25,100,400 --device-memory 4 --json $O/c-scale.json
date
