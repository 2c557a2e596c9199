#!/usr/bin/env bash
# Memory traffic of one lookup in a kept Ward set of `records_held`, for TRA and WF, under
# cachegrind (the VM exposes no hardware counters): each scheme is run once filling only and once
# with PASSES passes of the 16 384 queries, so the difference is the lookups'. Caches simulated:
# one core's (D1 32 KiB, LL 512 KiB), as verify/lookup_lines.sh does.
#
#   bash verify/records_held_lines.sh N [PASSES] [sorted]
#
# N is a kept set's target (run `cargo bench --bench records_held` first); PASSES 4 by default.
set -euo pipefail
n=${1:?usage: records_held_lines.sh N [PASSES] [sorted]}
passes=${2:-4}
order=${3:-}
command -v valgrind >/dev/null || { echo "valgrind is needed: apt-get install valgrind" >&2; exit 2; }
# valgrind does not know every instruction of a `target-cpu=native` build on this machine
# (`Illegal instruction`): the probe is built for x86-64-v3 in a target folder of its own. The
# layouts, and so the memory traffic, are the same.
target=${CARGO_TARGET_DIR:-target}/cachegrind
CARGO_TARGET_DIR=$target RUSTFLAGS="-C target-cpu=x86-64-v3" \
    cargo bench --bench records_held --no-run >/dev/null 2>&1
bin=$(ls -t "$target"/release/deps/records_held-* | grep -v '\.d$' | head -1)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# One number from cachegrind's summary: $1 file, $2 event label (e.g. "I *refs").
get() { grep -E "$2" "$1" | head -1 | sed -E 's/.*: *([0-9,]+).*/\1/' | tr -d ,; }

run() {
    valgrind --tool=cachegrind --cache-sim=yes --D1=32768,8,64 --LL=524288,8,64 \
        --cachegrind-out-file=/dev/null "$bin" --probe "$1" "$n" "$2" $order 2>"$tmp/err.$1.$2" >/dev/null
}

echo "| scheme | records (target) | order | instructions / lookup | data refs / lookup | D1 misses / lookup | LL misses / lookup |"
echo "|---|---:|---|---:|---:|---:|---:|"
for scheme in tra wf; do
    run "$scheme" 0
    run "$scheme" "$passes"
    lookups=$((passes * 16384))
    row="| $scheme | $n | ${order:-random}"
    for label in "I *refs" "D *refs" "D1 *misses" "LL misses"; do
        a=$(get "$tmp/err.$scheme.0" "$label")
        b=$(get "$tmp/err.$scheme.$passes" "$label")
        row="$row | $(awk -v a="$a" -v b="$b" -v l="$lookups" 'BEGIN { printf "%.1f", (b - a) / l }')"
    done
    echo "$row |"
done
