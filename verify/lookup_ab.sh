#!/usr/bin/env bash
# Lookup cost of this tree against a baseline commit, and of WF against TRA, measured in one run.
#
# Builds the `cache_ops` bench of the work tree and of BASE (a commit, built in a scratch git
# worktree beside this one), then runs `lookup/tra` and `lookup/wf` of each binary, alternating
# the binaries, ROUNDS times. Each run is a fresh process with a fresh cache (its own heap layout),
# so run-to-run spread on a shared machine is sampled rather than hidden; the medians over the
# rounds are compared, and WF/TRA is taken within each process and then its median.
#
# Usage: bash verify/lookup_ab.sh BASE [ROUNDS] [OUT.md]    (e.g. 355548e 10 results/lookup-floor/ab.md)
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:?usage: lookup_ab.sh BASE [ROUNDS] [OUT.md]}
rounds=${2:-10}
out=${3:-/dev/stdout}
scratch=target/ab-base
if [ ! -d "$scratch" ]; then
  git worktree add --detach -f "$scratch" "$base" >/dev/null
fi
git -C "$scratch" checkout --quiet --detach "$base"
bench_bin() { # $1: crate dir -> path of its cache_ops bench binary
  (cd "$1" && cargo bench --no-default-features --bench cache_ops --no-run --message-format=json 2>/dev/null) |
    grep -o '"executable":"[^"]*cache_ops[^"]*"' | tail -1 | cut -d'"' -f4
}
echo "building the baseline ($base) and this tree ..." >&2
base_bin=$(CARGO_TARGET_DIR=$PWD/target/ab-base-target bench_bin "$scratch")
new_bin=$(bench_bin .)
[ -x "$base_bin" ] && [ -x "$new_bin" ] || { echo "a bench binary is missing" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Criterion's median estimate (ns) of bench $2 in output $1.
median_ns() {
  awk -v id="$2" '$1 == id && $2 == "time:" { v = $5; u = $6 } END {
      if (u ~ /^µs/) v *= 1000; else if (u ~ /^ms/) v *= 1e6; print v }' "$1"
}
for r in $(seq 1 "$rounds"); do
  for which in base new; do
    bin=base_bin; [ $which = new ] && bin=new_bin
    "${!bin}" --bench '^lookup/(tra|wf)$' --noplot --discard-baseline >"$tmp/$which.$r" 2>&1
    echo "round $r/$rounds $which: tra $(median_ns "$tmp/$which.$r" lookup/tra) ns, wf $(median_ns "$tmp/$which.$r" lookup/wf) ns" >&2
  done
done
python3 - "$tmp" "$rounds" "$base" "$(git rev-parse --short HEAD)$(git diff --quiet || echo +changes)" >"$out" <<'PY'
import statistics, sys, re
tmp, rounds, base, new = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
def med(path, bench):
    v = None
    for line in open(path):
        f = line.split()
        if len(f) >= 6 and f[0] == bench and f[1] == "time:":
            v, u = float(f[4]), f[5]
            v *= {"ns": 1, "µs": 1e3, "ms": 1e6}[u.rstrip("]")]
    return v
runs = {(w, b): [med(f"{tmp}/{w}.{r}", f"lookup/{b}") for r in range(1, rounds + 1)]
        for w in ("base", "new") for b in ("tra", "wf")}
m = {k: statistics.median(v) for k, v in runs.items()}
ratio = [w / t for w, t in zip(runs[("new", "wf")], runs[("new", "tra")])]
ratio_base = [w / t for w, t in zip(runs[("base", "wf")], runs[("base", "tra")])]
q = lambda v: f"{min(v):.0f}–{max(v):.0f}"
print(f"Lookup A/B: baseline {base} against {new}, {rounds} alternating rounds, one process per run.\n")
print("| bench | baseline median (ns) | range | new median (ns) | range | new / baseline |")
print("|---|---:|---|---:|---|---:|")
for b in ("tra", "wf"):
    print(f"| lookup/{b} | {m[('base', b)]:.0f} | {q(runs[('base', b)])} | {m[('new', b)]:.0f} | {q(runs[('new', b)])} | {m[('new', b)] / m[('base', b)]:.3f} |")
print()
print(f"WF / TRA within each process, median over the rounds: baseline {statistics.median(ratio_base):.3f}, new {statistics.median(ratio):.3f} (rounds: {', '.join(f'{x:.3f}' for x in ratio)})")
PY
