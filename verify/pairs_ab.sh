#!/usr/bin/env bash
# WF against TRA on lookups, this tree against a baseline commit, in one run.
#
# Builds `benches/lookup_pairs.rs` of the work tree and of BASE (a commit, in the scratch git
# worktree that verify/lookup_ab.sh also uses), and the `lookup_profile` example of both. Then:
#  1. instructions per lookup of TRA and WF in each build, under cachegrind (deterministic: they do
#     not depend on the machine's load);
#  2. `lookup_pairs -- wf` of the two builds alternately, ROUNDS times each: every run times WF
#     against TRA in 101 ABBA rounds inside one process, so each figure is a same-process ratio,
#     and alternating the builds samples the hour's drift for both alike.
# Prints a markdown table (to OUT.md if given) with every run's median WF/TRA and the medians.
#
# Usage: bash verify/pairs_ab.sh BASE [ROUNDS] [OUT.md]    (e.g. 7043d2c 5 results/lookup-floor/pairs-ab.md)
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:?usage: pairs_ab.sh BASE [ROUNDS] [OUT.md]}
rounds=${2:-5}
out=${3:-/dev/stdout}
command -v valgrind >/dev/null || { echo "valgrind is needed: apt-get install valgrind" >&2; exit 2; }
scratch=target/ab-base
if [ ! -d "$scratch" ]; then
  git worktree add --detach -f "$scratch" "$base" >/dev/null
fi
git -C "$scratch" checkout --quiet --detach "$base"
# $1: crate dir -> path of its lookup_pairs bench binary
pairs_bin() {
  (cd "$1" && cargo bench --no-default-features --bench lookup_pairs --no-run --message-format=json 2>/dev/null) |
    grep -o '"executable":"[^"]*lookup_pairs[^"]*"' | tail -1 | cut -d'"' -f4
}
echo "building the baseline ($base) and this tree ..." >&2
export CARGO_TARGET_DIR_BASE=$PWD/target/ab-base-target
base_bin=$(CARGO_TARGET_DIR=$CARGO_TARGET_DIR_BASE pairs_bin "$scratch")
new_bin=$(pairs_bin .)
(cd "$scratch" && CARGO_TARGET_DIR=$CARGO_TARGET_DIR_BASE cargo build --quiet --release \
  --no-default-features --example lookup_profile)
cargo build --quiet --release --no-default-features --example lookup_profile
base_prof=$CARGO_TARGET_DIR_BASE/release/examples/lookup_profile
new_prof=target/release/examples/lookup_profile
for b in "$base_bin" "$new_bin" "$base_prof" "$new_prof"; do
  [ -x "$b" ] || { echo "missing binary $b" >&2; exit 1; }
done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Instructions per lookup: $1 profile binary, $2 scheme (two passes less none, over 2 x 16 384).
per_lookup() {
  local a b
  a=$(valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null "$1" "$2" 0 2>&1 |
    grep -E '== I *refs:' | sed -E 's/.*: *([0-9,]+).*/\1/' | tr -d ,)
  b=$(valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null "$1" "$2" 2 2>&1 |
    grep -E '== I *refs:' | sed -E 's/.*: *([0-9,]+).*/\1/' | tr -d ,)
  echo $(((b - a) / 32768))
}
echo "counting instructions ..." >&2
for which in base new; do
  prof=${which}_prof
  for s in tra wf; do per_lookup "${!prof}" "$s" >"$tmp/instr.$which.$s"; done
done
for r in $(seq 1 "$rounds"); do
  for which in base new; do
    bin=${which}_bin
    "${!bin}" wf >"$tmp/$which.$r" 2>&1
    echo "round $r/$rounds $which: $(grep '^| wf |' "$tmp/$which.$r")" >&2
  done
done
python3 - "$tmp" "$rounds" "$base" "$(git rev-parse --short HEAD)$(git diff --quiet || echo +changes)" >"$out" <<'PY'
import statistics, sys
tmp, rounds, base, new = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
instr = {(w, s): int(open(f"{tmp}/instr.{w}.{s}").read()) for w in ("base", "new") for s in ("tra", "wf")}
def row(path):
    for line in open(path):
        f = [c.strip() for c in line.strip().strip("|").split("|")]
        if f and f[0] == "wf":
            return float(f[1]), float(f[2]), float(f[3])
    raise SystemExit(f"no wf row in {path}")
runs = {w: [row(f"{tmp}/{w}.{r}") for r in range(1, rounds + 1)] for w in ("base", "new")}
print(f"WF against TRA on lookups: baseline {base} against {new}, {rounds} alternating runs of")
print("`lookup_pairs -- wf` (101 ABBA rounds each, in one process), and instructions per lookup")
print("under cachegrind.\n")
print("| | baseline | new |")
print("|---|---:|---:|")
for s in ("tra", "wf"):
    print(f"| instructions per lookup, {s.upper()} | {instr[('base', s)]} | {instr[('new', s)]} |")
print(f"| instructions, WF / TRA | {instr[('base', 'wf')] / instr[('base', 'tra')]:.3f} | {instr[('new', 'wf')] / instr[('new', 'tra')]:.3f} |")
for r in range(rounds):
    b, n = runs["base"][r], runs["new"][r]
    print(f"| run {r + 1}: WF / TRA (WF ns, TRA ns) | {b[2]:.3f} ({b[0]:.0f}, {b[1]:.0f}) | {n[2]:.3f} ({n[0]:.0f}, {n[1]:.0f}) |")
med = {w: statistics.median(x[2] for x in runs[w]) for w in runs}
print(f"| **median of the runs, WF / TRA** | **{med['base']:.3f}** | **{med['new']:.3f}** |")
PY
