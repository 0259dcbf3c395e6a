#!/usr/bin/env bash
# The browser test: builds the web page (scripts/build-web.sh), runs the same small demo
# scene natively (`mvscope run` + `mvscope eval`) and in Debian's chromium (headless,
# WebGPU on SwiftShader) through tests/web/run.mjs, which compares the two runs' scores and
# checks a screenshot. Needs chromium and node (.ci/run installs them).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-target/web-test}
mkdir -p "$out"

bash scripts/build-web.sh
(cd tests/web && npm ci --no-audit --no-fund --silent)

# The demo the page runs (tests/web/run.mjs: 96x72, 3 views), natively.
# The dev profile's binary with the test build's features: what `cargo test --all-features`
# has already built in CI (without them cargo rebuilds the viewer's stack, ~10 min on 2 cores).
cargo build --all-features --bin mvscope
bin=target/debug/mvscope
rm -rf "$out/demo" "$out/native"
"$bin" demo --out "$out/demo" --width 96 --height 72 --views 3 >/dev/null
"$bin" run "$out/demo" --out "$out/native" --method acmm --no-fuse >/dev/null
"$bin" eval "$out/native" --gt "$out/demo" >/dev/null

node tests/web/run.mjs --web target/web --native "$out/native/eval.json" --out "$out"
