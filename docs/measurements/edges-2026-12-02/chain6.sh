cd /work/main
while [ ! -f /tmp/s31/chain5.done ]; do sleep 5; done
B=target/release/mvscope; M=/tmp/s31
export XDG_RUNTIME_DIR=/tmp/xdg-runtime-0
$B run /tmp/s30/syn --max-image-size 320 --method regions --seed 0 --no-fuse --out $M/syn-n > $M/syn-n-run.log 2>&1
PATH=/tmp/uvenv/bin:$PATH python docs/measurements/weighted-flat-2026-12-01/edge_error.py $M/syn-n /tmp/s30/syn > $M/syn-n-bands.log 2>&1
echo done > $M/chain6.done
