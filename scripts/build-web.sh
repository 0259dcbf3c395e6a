#!/usr/bin/env bash
# Builds the viewer as a static web page into target/web/ (index.html, mvscope.js,
# mvscope_bg.wasm, icon.svg): any static file server can host the folder. The same crate as
# the native viewer, compiled for wasm32 and bound to JavaScript by wasm-bindgen, whose CLI
# is pinned to the wasm-bindgen crate version in Cargo.toml (they must match exactly).
set -euo pipefail
cd "$(dirname "$0")/.."

WASM_BINDGEN_VERSION=0.2.130
out=target/web

if command -v rustup >/dev/null; then
    rustup target add wasm32-unknown-unknown >/dev/null
fi
if ! wasm-bindgen --version 2>/dev/null | grep -q " $WASM_BINDGEN_VERSION\$"; then
    echo "installing wasm-bindgen-cli $WASM_BINDGEN_VERSION"
    cargo install wasm-bindgen-cli --version "=$WASM_BINDGEN_VERSION"
fi

cargo build --release --target wasm32-unknown-unknown --bin mvscope
rm -rf "$out"
mkdir -p "$out"
wasm-bindgen --target web --no-typescript --out-dir "$out" --out-name mvscope \
    target/wasm32-unknown-unknown/release/mvscope.wasm
# wasm-opt (binaryen) shrinks the module further where it is installed; optional.
if command -v wasm-opt >/dev/null; then
    wasm-opt -O2 --enable-bulk-memory --enable-nontrapping-float-to-int \
        "$out/mvscope_bg.wasm" -o "$out/mvscope_bg.wasm"
fi
cp assets/index.html assets/icon.svg "$out/"
echo "wrote $out ($(du -h "$out/mvscope_bg.wasm" | cut -f1) of wasm): serve it, e.g. python3 -m http.server -d $out"
