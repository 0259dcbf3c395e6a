cd /work/main
B=target/release/mvscope; M=/tmp/s30
export XDG_RUNTIME_DIR=/tmp/xdg-runtime-0
W="--set prior_flat_weighted=true"
$B bench --accuracy $M/kroot --scenes kitchen-a --max-image-size 320 --methods regions --seeds 0 $W --json $M/k526-regw.json > $M/k526-regw.log 2>&1
$B run ../shared/data/rgbd/icl-livingroom --max-image-size 320 --method acmm --seed 0 --no-fuse --out $M/icl-acmm > $M/icl-acmm.log 2>&1
mkdir -p $M/iroot/rgbd
$B eval $M/icl-acmm --gt ../shared/data/rgbd/icl-livingroom --write-cameras $M/iroot/rgbd/icl-livingroom > $M/icl-write.log 2>&1
$B bench --accuracy $M/iroot --scenes icl --max-image-size 320 --methods regions --seeds 0 $W --json $M/regicl-regw.json > $M/regicl-regw.log 2>&1
$B bench --accuracy $M/iroot --scenes icl --max-image-size 320 --methods regions --seeds 0 --json $M/regicl-reg.json > $M/regicl-reg.log 2>&1
MID=Adirondack,ArtL,Teddy,Aloe,Baby1,Bowling1,Dolls,Flowerpots,Lampshade1,Midd1,Wood1
$B bench --accuracy ../shared/data --scenes $MID --max-image-size 320 --methods regions --seeds 0 $W --json $M/mid-regw.json > $M/mid-regw.log 2>&1
echo done > $M/chain2.done
