export XDG_RUNTIME_DIR=/tmp/xdg-runtime-0
cd /work/main
B=/tmp/s32/$1
$B bench --accuracy ../shared/data --scenes icl --max-image-size 320 --methods regions --seeds 0 --json /tmp/s32/$1-icls.json > /tmp/s32/$1-icls.log 2>&1
$B bench --accuracy /tmp/s30/iroot --scenes icl-livingroom --max-image-size 320 --methods regions --seeds 0,1,2 --json /tmp/s32/$1-icl.json > /tmp/s32/$1-icl.log 2>&1
$B bench --accuracy ../shared/data --scenes synthetic-320 --max-image-size 320 --methods regions --seeds 0 --json /tmp/s32/$1-syn.json > /tmp/s32/$1-syn.log 2>&1
$B bench --accuracy ../shared/data --scenes Adirondack,ArtL,Teddy,Aloe,Baby1,Bowling1,Dolls,Flowerpots,Lampshade1,Midd1,Wood1 --max-image-size 320 --methods regions --seeds 0 --json /tmp/s32/$1-mid.json > /tmp/s32/$1-mid.log 2>&1
touch /tmp/s32/$1.done5
