#!/usr/bin/env bash
# Memory traffic of one lookup on the cache_ops workload, per scheme, measured by cachegrind:
# the lookup_profile example is run twice per scheme, once building the cache only (0 passes)
# and once also looking up every query PASSES times; the difference, divided by the lookups, is
# what one lookup costs. Caches simulated as one core of this machine (2 cores: 64 KiB of L1d and
# 1 MiB of L2 in all): D1 = 32 KiB 8-way, last level = the 512 KiB 8-way L2 (a miss there goes
# to the shared L3, about 40 ns away).
# Usage: bash verify/lookup_lines.sh [SCHEMES...]   (default: tra wf)
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || { echo "valgrind is needed: apt-get install valgrind" >&2; exit 2; }
PASSES=2
schemes=("$@")
[ ${#schemes[@]} -eq 0 ] && schemes=(tra wf)
cargo build --quiet --release --no-default-features --example lookup_profile
bin=target/release/examples/lookup_profile
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# One number from cachegrind's summary: $1 file, $2 event label (e.g. "I *refs").
field() { grep -E "== $2:" "$1" | head -1 | sed -E 's/.*: *([0-9,]+).*/\1/' | tr -d ,; }
printf '| scheme | instructions | data reads+writes | D1 misses (32 KiB) | L2 misses (512 KiB) |\n'
printf '|---|---:|---:|---:|---:|\n'
for s in "${schemes[@]}"; do
  for n in 0 $PASSES; do
    valgrind --tool=cachegrind --cache-sim=yes --D1=32768,8,64 --LL=524288,8,64 \
      --cachegrind-out-file=/dev/null "$bin" "$s" "$n" >"$tmp/out.$n" 2>"$tmp/err.$n"
  done
  lookups=$(sed -E 's/^([0-9]+) lookups.*/\1/' "$tmp/out.$PASSES")
  per() { echo "scale=1; ($(field "$tmp/err.$PASSES" "$1") - $(field "$tmp/err.0" "$1")) / $lookups" | bc; }
  printf '| %s | %s | %s | %s | %s |\n' "$s" "$(per 'I *refs')" "$(per 'D *refs')" \
    "$(per 'D1  misses')" "$(per 'LLd misses')"
done
