cd /work/main
B=target/release/mvscope; M=/tmp/s27/m
G="--set bilateral_kernel=gaussian --set sigma_color=3"
MID=Adirondack,ArtL,Teddy,Aloe,Baby1,Bowling1,Dolls,Flowerpots,Lampshade1,Midd1,Wood1
$B bench --accuracy /tmp/s26/regroot --scenes icl --max-image-size 320 --methods regions --seeds 0 $G --json $M/regicl-g3.json > $M/regicl-g3.log 2>&1
$B bench --accuracy ../shared/data --scenes $MID --max-image-size 320 --methods regions --seeds 0 $G --json $M/mid-reg-g3.json > $M/mid-reg-g3.log 2>&1
$B bench --accuracy /tmp/s26/regroot --scenes icl --max-image-size 320 --methods acmm --seeds 0 $G --json $M/regicl-acmm-g3.json > $M/regicl-acmm-g3.log 2>&1
$B bench --accuracy ../shared/data --scenes $MID --max-image-size 320 --methods acmm --seeds 0 $G --json $M/mid-acmm-g3.json > $M/mid-acmm-g3.log 2>&1
$B bench --accuracy ../shared/data --scenes $MID --max-image-size 320 --methods acmm --seeds 0 --json $M/mid-acmm.json > $M/mid-acmm.log 2>&1
$B bench --accuracy ../shared/data --scenes synthetic-320 --max-image-size 320 --methods acmm --seeds 0 $G --json $M/syn-acmm-g3.json > $M/syn-acmm-g3.log 2>&1
echo done > $M/chain.done
