cd /work/main
B=target/release/mvscope; M=/tmp/s28
export XDG_RUNTIME_DIR=/tmp/xdg
# Regions' default is the adaptive weight in this binary.
$B bench --accuracy ../shared/data --scenes synthetic-room --max-image-size 320 --methods regions --seeds 0 --json $M/room-reg-ad.json > $M/room-reg-ad.log 2>&1
$B bench --accuracy ../shared/data --scenes icl --max-image-size 320 --methods regions --seeds 0 --json $M/icl-reg-ad.json > $M/icl-reg-ad.log 2>&1
echo done > $M/chain2.done
