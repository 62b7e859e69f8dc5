#!/bin/sh
# Runs the C peer (../shared/peers/c-libmvec) and this crate's in-cache RGB transmittance
# benchmark back to back on the same data sets, for the README's speed table.
# Usage: benches/compare_peer.sh   (from the repository root)
set -e
peer=${PEER:-../shared/peers/c-libmvec/run.sh}
echo "== C peer: $peer 65536 200"
sh "$peer" 65536 200
echo "== analytic-fog: cargo bench --bench height_fog -- transmittance_rgb"
FOG_BENCH_STREAM=0 cargo bench --bench height_fog -- transmittance_rgb 2>&1 |
    grep -E "^transmittance_rgb|time:" | paste - - |
    awk '{ t = $(NF-3); u = $(NF-2); ns = t; if (u == "ms") ns = t * 1e6; else if (u == "µs" || u == "us") ns = t * 1e3;
           printf "%-40s %8.3f ns/ray\n", $1, ns / 65536 }'
