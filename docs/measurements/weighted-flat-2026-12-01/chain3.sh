cd /work/main
while [ ! -f /tmp/s30/chain2.done ]; do sleep 10; done
B=target/release/mvscope; M=/tmp/s30
export XDG_RUNTIME_DIR=/tmp/xdg-runtime-0
$B bench --accuracy ../shared/data --scenes synthetic-320 --max-image-size 320 --methods regions --seeds 0 --set prior_flat_weighted=true --json $M/syn-regw2.json > $M/syn-regw2.log 2>&1
$B bench --accuracy $M/kroot --scenes kitchen-a --max-image-size 320 --methods regions --seeds 0 --json $M/k526-reg.json > $M/k526-reg.log 2>&1
echo done > $M/chain3.done
