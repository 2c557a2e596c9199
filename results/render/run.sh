#!/usr/bin/env bash
# Every renderer figure quoted in paper-notes.md ("The renderer and its five scenes"), run from the
# repository root: bash results/render/run.sh. Writes the statistics and text into results/render/,
# the five scene images into docs/img/, and every other image (PNG, PFM, overlays) into
# target/render-results/ (not committed: each is a few megabytes, and this script remakes them).
set -euo pipefail
cd "$(dirname "$0")/../.."
out=results/render
img=target/render-results
mkdir -p $img
cargo build --release --bins --examples
wfic=./target/release/wfic

# The five scenes at 320 x 320, wf, 2 threads (README and paper-notes images; scene table).
for s in cornell desk conference office sponza; do
    $wfic render --scene $s --scheme wf --threads 2 --width 320 --height 320 --quiet \
        --out $img/$s-320.png --records $img/$s-320-records.png --stats $out/$s-320.json
    # The PNG alone goes to docs/img/ (the PFM and HDR beside it are megabytes).
    cp $img/$s-320.png docs/img/$s.png
done
cp $img/cornell-320-records.png docs/img/cornell-records.png

# One still frame per scheme: Cornell 512 x 512, default settings, empty cache.
for s in tra lck lck-rw lw wf wf-discard; do
    t=2; [ $s = tra ] && t=1
    $wfic render --scene cornell --scheme $s --threads $t --quiet \
        --out $img/cornell-512-$s.png --stats $out/cornell-512-$s.json
done
# wf on one thread three times (the time per frame), and the reference without a cache.
for i in 1 2 3; do
    $wfic render --scene cornell --scheme wf --threads 1 --quiet \
        --out $img/cornell-512-wf-1t.png --stats $out/cornell-512-wf-1t-run$i.json
done
$wfic render --scene cornell --scheme none --threads 2 --quiet \
    --out $img/cornell-512-none.png --stats $out/cornell-512-none.json

# Accuracy against the reference, every scene and scheme (the ignored test prints its tables).
cargo test --release --test render -- --ignored --nocapture > $out/accuracy.txt 2>&1

# The reference's own noise, and wf against a 4 096-ray reference.
REF_RAYS=4096 cargo run --release --example compare -- 128 2 office sponza cornell \
    > $out/compare-ref4096.txt
NOISE=1 cargo run --release --example compare -- 128 2 > $out/compare-noise.txt

# Frame time per scheme at 128 x 128 (criterion).
cargo bench --bench render > $out/bench-render.txt 2>&1
