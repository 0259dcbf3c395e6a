set -u
OLD=/tmp/old/target/release/mvscope   # 4cfd0c9 (before the session-49 defaults), cargo build --release in its own clone
NEW=/work/main/target/release/mvscope   # b60091a
export XDG_RUNTIME_DIR=/tmp/xdg
mkdir -p /tmp/s50 && cd /tmp/s50   # as run: the copied line cd-ed to a missing folder and the script ran here
$NEW demo --out demo --width 96 --height 72 --views 5 >/dev/null 2>&1
cmpdir() {
  local bad=0 n=0
  for f in $(cd $1 && find depth normal cost confidence -type f | sort) fused.ply; do
    n=$((n+1)); cmp -s $1/$f $2/$f || { echo "DIFF $1/$f"; bad=1; }
  done
  echo "$3: $n files, $([ $bad = 0 ] && echo identical || echo DIFFERENT)"
}
for m in dwta acmh acmm acmp acmmp regions; do
  case $m in acmp|acmmp|regions) mem=1.4;; *) mem=0.9;; esac
  for b in OLD NEW; do
    bin=${!b}
    $bin run demo --out $b-$m --method $m >/dev/null 2>&1 || echo "run failed $b $m"
    $bin run demo --out $b-$m-budget --method $m --device-memory $mem >/dev/null 2>&1 || echo "budget run failed $b $m"
  done
  cmpdir OLD-$m NEW-$m "$m whole"
  cmpdir OLD-$m-budget NEW-$m-budget "$m budget $mem MiB ($(grep -o '"batches": [0-9]*' NEW-$m-budget/report.json | head -1))"
  cmpdir NEW-$m NEW-$m-budget "$m budget vs whole (new)"
done
for m in acmm regions acmmp; do
  for b in OLD NEW; do
    bin=${!b}
    $bin plan demo --out $b-$m-chain --method $m --tasks 2 >/dev/null 2>&1
    k=$(python3 -c "import json;print(len(json.load(open('$b-$m-chain/plan.json'))['stages']))")
    for s in $(seq 0 $((k-1))); do for c in 0 1; do $bin task $b-$m-chain --stage $s --chunk $c >/dev/null 2>&1 || echo "task failed $b $m $s $c"; done; done
    $bin task $b-$m-chain --fuse >/dev/null 2>&1
  done
  cmpdir OLD-$m-chain NEW-$m-chain "$m cluster chain"
  cmpdir NEW-$m NEW-$m-chain "$m chain vs whole (new)"
done
