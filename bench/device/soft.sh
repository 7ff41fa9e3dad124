#!/usr/bin/env bash
# Runs the soft-body bench (`inertia-bench soft`, every case: the cloths,
# the jelly and the fluids on the CPU at 1 and 2 threads and on the GPU,
# with the GPU's distance from the CPU, and the GPU-only `fluid_1m`) on a machine with a real GPU, in
# under five minutes, and writes the records where they can be committed
# (bench/results/<machine>.jsonl). SOFT_ONLY runs one selection instead
# (a substring of the case names, e.g. `cloth_128`).
#
#   bench/device/soft.sh [OUT_DIR]
#
# OUT_DIR defaults to $OUT (the device machine's result folder) or
# target/device. The binary is $INERTIA_BENCH when set (a release build
# carried to a machine that cannot fetch crates), else it is built here
# with cargo (about 3 minutes cold on 16 cores). Vulkan: when the repo
# holds .gl/ (the loader packages, see the device notes), they are
# unpacked first; NVIDIA's ICD is used where the driver ships it.
set -euo pipefail
cd "$(dirname "$0")/../.."
out=${1:-${OUT:-target/device}}
mkdir -p "$out"
bin=${INERTIA_BENCH:-}
if [ -z "$bin" ]; then
    cargo build --release -p inertia-bench
    bin=target/release/inertia-bench
fi
if [ -d .gl ]; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -f "$icd" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
    export VK_DRIVER_FILES=$icd
fi
start=$(date +%s)
if [ -n "${SOFT_ONLY:-}" ]; then
    "$bin" soft --json --only "$SOFT_ONLY" | tee "$out/soft.jsonl"
else
    "$bin" soft --json | tee "$out/soft.jsonl"
fi
"$bin" soft --plot "$out" --from "$out/soft.jsonl" 2>&1
echo "soft bench: $(($(date +%s) - start)) s; records in $out/soft.jsonl, plot in $out/soft.svg" >&2
