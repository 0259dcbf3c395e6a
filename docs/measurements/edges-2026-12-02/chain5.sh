cd /work/main
B=target/release/mvscope; M=/tmp/s31
export XDG_RUNTIME_DIR=/tmp/xdg-runtime-0
MID=Adirondack,ArtL,Teddy,Aloe,Baby1,Bowling1,Dolls,Flowerpots,Lampshade1,Midd1,Wood1
$B bench --accuracy /tmp/s30/iroot --scenes icl-livingroom --max-image-size 320 --methods regions --seeds 0 --json $M/n-icl.json > $M/n-icl.log 2>&1
$B bench --accuracy ../shared/data --scenes synthetic-320 --max-image-size 320 --methods regions --seeds 0 --json $M/n-syn.json > $M/n-syn.log 2>&1
$B bench --accuracy ../shared/data --scenes $MID --max-image-size 320 --methods regions --seeds 0 --json $M/n-mid.json > $M/n-mid.log 2>&1
$B bench --accuracy /tmp/s30/kroot --scenes kitchen-a --max-image-size 320 --methods regions --seeds 0 --json $M/n-ka.json > $M/n-ka.log 2>&1
$B bench --accuracy ../shared/data --scenes synthetic-room --max-image-size 320 --methods regions --seeds 0 --json $M/n-room.json > $M/n-room.log 2>&1
$B bench --accuracy ../shared/data --scenes icl --max-image-size 320 --methods regions --seeds 0 --json $M/n-icls.json > $M/n-icls.log 2>&1
echo done > $M/chain5.done
