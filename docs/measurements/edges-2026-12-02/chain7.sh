cd /work/main
while [ ! -f /tmp/s31/chain6.done ]; do sleep 5; done
B=target/release/mvscope; M=/tmp/s31
export XDG_RUNTIME_DIR=/tmp/xdg-runtime-0
$B bench --accuracy ../shared/data --scenes icl --max-image-size 320 --methods regions --seeds 0 --set prior_region_edge=false --json $M/s-icls-w.json > $M/s-icls-w.log 2>&1
$B bench --accuracy ../shared/data --scenes icl --max-image-size 320 --methods regions --seeds 0 --set prior_flat_weighted=false --json $M/s-icls-e.json > $M/s-icls-e.log 2>&1
$B bench --accuracy ../shared/data --scenes icl --max-image-size 320 --methods regions --seeds 0 --set prior_flat_weighted=false --set prior_region_edge=false --json $M/s-icls-0.json > $M/s-icls-0.log 2>&1
echo done > $M/chain7.done
