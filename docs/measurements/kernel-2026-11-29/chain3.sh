cd /work/main
cp target/release/mvscope /tmp/s27/mvscope-new
B=/tmp/s27/mvscope-new; M=/tmp/s27/n
MID=Adirondack,ArtL,Teddy,Aloe,Baby1,Bowling1,Dolls,Flowerpots,Lampshade1,Midd1,Wood1
$B bench --accuracy ../shared/data --scenes synthetic-320 --max-image-size 320 --methods regions --seeds 0 --json $M/syn-reg.json > $M/syn-reg.log 2>&1
$B bench --accuracy /tmp/s26/regroot --scenes icl --max-image-size 320 --methods regions --seeds 0 --json $M/regicl-reg.json > $M/regicl-reg.log 2>&1
$B bench --accuracy ../shared/data --scenes $MID --max-image-size 320 --methods regions --seeds 0 --json $M/mid-reg.json > $M/mid-reg.log 2>&1
$B bench --accuracy ../shared/data --scenes synthetic-room --max-image-size 320 --methods regions --seeds 0 --json $M/room-reg.json > $M/room-reg.log 2>&1
echo done > $M/chain3.done
