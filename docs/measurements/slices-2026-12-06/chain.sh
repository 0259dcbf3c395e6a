#!/bin/bash
set -x
export XDG_RUNTIME_DIR=/tmp/xdg; mkdir -p $XDG_RUNTIME_DIR; chmod 700 $XDG_RUNTIME_DIR
B=/tmp/m/mvscope-slices   # a copy, so rebuilding target/ does not change the binary mid-run
cd /work/main
if [ ! -d /tmp/scenes/extra/rgbd/icl-reg ]; then
  $B run ../shared/data/rgbd/icl-livingroom --out /tmp/m/icl-acmm --method acmm --max-image-size 320 --seed 0 > /tmp/m/icl-acmm.log 2>&1
  $B eval /tmp/m/icl-acmm --gt ../shared/data/rgbd/icl-livingroom --write-cameras /tmp/scenes/extra/rgbd/icl-reg > /tmp/m/icl-reg-write.log 2>&1
fi
$B bench --accuracy /tmp/scenes/extra --max-image-size 320 --methods regions --seeds 0 --json /tmp/m/extra-regions.json > /tmp/m/extra-regions.log 2>&1
$B bench --accuracy ../shared/data --max-image-size 320 --methods regions --seeds 0 --json /tmp/m/all320-regions.json > /tmp/m/all320-regions.log 2>&1
echo chain done
