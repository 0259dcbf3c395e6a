cd /work/main
while [ ! -f /tmp/s31/e-mid.json ]; do sleep 3; done
sleep 5
B=target/release/mvscope; M=/tmp/s31
export XDG_RUNTIME_DIR=/tmp/xdg-runtime-0
$B bench --accuracy /tmp/s30/iroot --scenes icl-livingroom --max-image-size 320 --methods regions --seeds 0 --set prior_region_edge=false --json $M/k-icl.json > $M/k-icl.log 2>&1
echo done > $M/chain9.done
