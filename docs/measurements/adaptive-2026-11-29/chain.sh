cd /work/main
B=target/release/mvscope; M=/tmp/s28
A="--set bilateral_kernel=adaptive"
MID=Adirondack,ArtL,Teddy,Aloe,Baby1,Bowling1,Dolls,Flowerpots,Lampshade1,Midd1,Wood1
export XDG_RUNTIME_DIR=/tmp/xdg
$B bench --accuracy /tmp/s27/k526 --scenes kitchen-a --max-image-size 320 --methods regions --seeds 0 $A --json $M/k526-reg-ad.json > $M/k526-reg-ad.log 2>&1
$B bench --accuracy /tmp/s26/regroot --scenes icl --max-image-size 320 --methods regions --seeds 0 $A --json $M/regicl-reg-ad.json > $M/regicl-reg-ad.log 2>&1
$B bench --accuracy ../shared/data --scenes synthetic-320 --max-image-size 320 --methods regions --seeds 0 $A --json $M/syn-reg-ad.json > $M/syn-reg-ad.log 2>&1
$B bench --accuracy ../shared/data --scenes $MID --max-image-size 320 --methods regions --seeds 0 $A --json $M/mid-reg-ad.json > $M/mid-reg-ad.log 2>&1
echo done > $M/chain.done
