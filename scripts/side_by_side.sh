#!/usr/bin/env bash
# mvscope against the authors' original CUDA ACMM on the same folder and GPU (docs/side-by-side.md).
#
#   scripts/side_by_side.sh [FOUNTAIN_DIR] [WORK_DIR]
#
# Needs: an NVIDIA GPU with its driver (nvidia-smi), network access (pip, git, apt), python3,
# cmake, g++, and as root or with sudo: apt-get install libopencv-dev. Writes everything under
# WORK_DIR (default ./side-by-side) and prints time per view for both and how well their depth
# maps agree.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
fountain="${1:-$here/../shared/data/fountain-P11}"
work="$(mkdir -p "${2:-side-by-side}" && cd "${2:-side-by-side}" && pwd)"

command -v nvidia-smi >/dev/null || { echo "no nvidia-smi: this recipe needs an NVIDIA GPU" >&2; exit 1; }
cap="$(nvidia-smi --query-gpu=compute_cap --format=csv,noheader | head -1 | tr -d '.')"
echo "== GPU: $(nvidia-smi --query-gpu=name --format=csv,noheader | head -1) (sm_$cap)"

# --- CUDA compiler from PyPI, OpenCV from the distribution.
if ! dpkg -s libopencv-dev >/dev/null 2>&1; then
    sudo=""; [ "$(id -u)" = 0 ] || sudo=sudo
    $sudo apt-get update -qq && $sudo apt-get install -y -qq libopencv-dev cmake g++ >/dev/null
fi
python3 -m venv "$work/venv"
"$work/venv/bin/pip" install -q nvidia-cuda-nvcc-cu12 nvidia-cuda-runtime-cu12 numpy
cuda="$("$work/venv/bin/python" -c 'import nvidia.cuda_nvcc, os; print(os.path.dirname(nvidia.cuda_nvcc.__path__[0]))')"
nvcc_dir="$cuda/cuda_nvcc"
rt_dir="$cuda/cuda_runtime"
export PATH="$nvcc_dir/bin:$PATH"
# The runtime's library has a versioned name only; the linker wants libcudart.so.
[ -e "$rt_dir/lib/libcudart.so" ] || ln -s "$(ls "$rt_dir"/lib/libcudart.so.* | head -1)" "$rt_dir/lib/libcudart.so"

# --- The original, built for this GPU. Its CMakeLists names one -gencode; a wrong one yields
# all-zero depth maps without an error, so it is replaced by this GPU's.
if [ ! -x "$work/ACMM/build/ACMM" ]; then
    [ -d "$work/ACMM" ] || git clone -q https://github.com/GhiXu/ACMM "$work/ACMM"
    sed -i -E "s/arch=compute_[0-9]+,code=sm_[0-9]+/arch=compute_$cap,code=sm_$cap/g" "$work/ACMM/CMakeLists.txt"
    cmake -S "$work/ACMM" -B "$work/ACMM/build" -DCMAKE_BUILD_TYPE=Release \
        -DCUDA_TOOLKIT_ROOT_DIR="$nvcc_dir" -DCMAKE_CUDA_COMPILER="$nvcc_dir/bin/nvcc" \
        -DCUDA_INCLUDE_DIRS="$nvcc_dir/include;$rt_dir/include" \
        -DCUDA_CUDART_LIBRARY="$rt_dir/lib/libcudart.so" >/dev/null
    make -C "$work/ACMM/build" -j"$(nproc)" >/dev/null
fi

# --- mvscope, and the scene as an ACMM folder (full size) that both read.
cargo build --release --manifest-path "$here/Cargo.toml" >/dev/null
mvscope="$here/target/release/mvscope"
[ -f "$work/fountain-acmm/pair.txt" ] || "$mvscope" convert "$fountain" --to acmm --out "$work/fountain-acmm"
views="$(ls "$work/fountain-acmm/images" | wc -l)"

# --- The original: depth maps of every view (its fusion is a separate step, not timed).
rm -rf "$work/fountain-acmm/ACMM"
t0=$(date +%s.%N)
LD_LIBRARY_PATH="$rt_dir/lib:${LD_LIBRARY_PATH:-}" "$work/ACMM/build/ACMM" "$work/fountain-acmm" > "$work/acmm.log" 2>&1
t1=$(date +%s.%N)

# --- mvscope with the original's schedule: its pyramid (halve to <= 1000 px), photometric 3,
# 2 geometric passes of 2 iterations, and its depth-range widening. Fusion off, as above.
"$mvscope" run "$work/fountain-acmm" --out "$work/mvscope" --method acmm --no-fuse \
    --set original_pyramid=true --set coarse_iterations=3 --set restorer_iterations=3 \
    --set geometric_passes=2 --set geometric_iterations=2 \
    --set depth_min_factor=0.6 --set depth_max_factor=1.2 > "$work/mvscope.log" 2>&1
t2=$(date +%s.%N)

"$work/venv/bin/python" - "$work" "$views" "$t0" "$t1" "$t2" <<'PY'
import sys, struct, glob, os
import numpy as np
work, views, t0, t1, t2 = sys.argv[1], int(sys.argv[2]), *map(float, sys.argv[3:])
def dmb(path):
    with open(path, 'rb') as f:
        _, h, w, c = struct.unpack('<4i', f.read(16))
        return np.frombuffer(f.read(), '<f4').reshape(h, w, c)[..., 0]
def pfm(path):
    with open(path, 'rb') as f:
        kind = f.readline().strip(); w, h = map(int, f.readline().split()); scale = float(f.readline())
        data = np.frombuffer(f.read(), '<f4' if scale < 0 else '>f4')
        return np.flipud(data.reshape(h, w, -1))[..., 0]
print(f"original ACMM: {t1 - t0:.1f} s for {views} views ({(t1 - t0) / views:.2f} s per view)")
print(f"mvscope ACMM:  {t2 - t1:.1f} s for {views} views ({(t2 - t1) / views:.2f} s per view), "
      "including loading and writing")
agree1, agree5, both = 0, 0, 0
for v in range(views):
    a_path = os.path.join(work, 'fountain-acmm', 'ACMM', f'2333_{v:08d}', 'depths_geom.dmb')
    if not os.path.exists(a_path):
        a_path = a_path.replace('depths_geom', 'depths')
    a, b = dmb(a_path), pfm(os.path.join(work, 'mvscope', 'depth', f'{v:08d}.pfm'))
    if a.shape != b.shape:
        print(f"view {v}: sizes differ {a.shape} vs {b.shape}"); continue
    ok = (a > 0) & (b > 0)
    rel = np.abs(a[ok] - b[ok]) / a[ok]
    both += ok.sum(); agree1 += (rel < 0.01).sum(); agree5 += (rel < 0.05).sum()
print(f"depth agreement over {both} pixels both estimate: {100 * agree1 / max(both, 1):.1f}% "
      f"within 1%, {100 * agree5 / max(both, 1):.1f}% within 5%")
PY
