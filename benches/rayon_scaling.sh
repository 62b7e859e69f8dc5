#!/bin/bash
# Rayon scaling: `streaming_16m/{x8_rayon,copy_rayon}/typical` (benches/height_fog.rs) and
# `pass/{fog_par,plain_par}` (benches/pass.rs) with RAYON_NUM_THREADS = 1, 2, 4, 8, 16, for
# the x86-64-v3 build and, where the CPU has AVX-512F, the x86-64-v4 build.
#
# It runs prebuilt, stripped bench binaries from a directory, so that it can run on a
# machine without a Rust toolchain. Build them with:
#   mkdir -p target-dev
#   cargo bench --no-run --bench height_fog --bench pass   # prints the two executables
#   (copy them to target-dev/height_fog_main and target-dev/pass_main; the same with
#    CARGO_TARGET_DIR=target-v4 RUSTFLAGS="-C target-cpu=x86-64-v4" to *_v4; strip all)
# then: benches/rayon_scaling.sh target-dev   (THREADS="1 16" to choose thread counts)
set -u
dir=${1:-target-dev}
export CRITERION_HOME=${OUT:-/tmp}/criterion
lscpu | grep -iE "model name|^CPU\(s\)|L3|Thread|Socket|NUMA node\(s\)"
grep -o -m1 'avx512f' /proc/cpuinfo || echo "no avx512f"
uptime
A="--warm-up-time 0.5 --measurement-time 2 --noplot"
BUILDS=main
grep -q avx512f /proc/cpuinfo && BUILDS="$BUILDS v4"
for b in $BUILDS; do
  for n in ${THREADS:-1 2 4 8 16}; do
    echo "== build $b threads $n"
    RAYON_NUM_THREADS=$n timeout 200 "$dir/height_fog_$b" --bench $A \
      'streaming_16m/(x8_rayon|copy_rayon)/typical' 2>&1 | grep -E "^streaming|time:" | grep -v "%"
    RAYON_NUM_THREADS=$n timeout 100 "$dir/pass_$b" --bench $A \
      'pass/(fog_par|plain_par)' 2>&1 | grep -E "^pass/|time:" | grep -v "%"
  done
done
