#!/usr/bin/env bash
# Mutation testing with cargo-mutants over the caches (src/cache), the irradiance-cache maths
# (src/ic) and the history checkers (src/research/lincheck).
#
#   bash verify/mutants.sh [wf|cache|ic|lincheck|all]      (default: all)
#   bash verify/mutants.sh wf-lookup|cache-lookup           (the files or functions the lean read
#                                                            path rewrote, when a scope does not fit)
#   bash verify/mutants.sh wf-removal                       (the functions of src/cache/wf that
#                                                            removal added or changed)
#   bash verify/mutants.sh cache-removal|ic-removal|lincheck-removal
#                                                           (the lines of src/cache/*.rs, src/ic or
#                                                            src/research/lincheck that removal changed: the
#                                                            diff from $removal_base, --in-diff)
#   bash verify/mutants.sh deterministic                    (the lines of src/cache and src/ic
#                                                            that deterministic frames changed)
#   bash verify/mutants.sh cache-work                       (the lines of src/cache/*.rs that
#                                                            counting removal's work changed)
#   bash verify/mutants.sh wf-compact                       (the lines of src/cache/wf that the
#                                                            frame's close rebuilding grown lists
#                                                            as one block changed)
#   bash verify/mutants.sh render-tiles|render-distributed  (the renderer's tile loop and work
#                                                            source; its MPI exchange, with the
#                                                            mpi feature: needs OpenMPI, as CI)
#   bash verify/mutants.sh bounds|render-limits              (the lines of src/cache the command
#                                                            line's bounds changed; the renderer's
#                                                            ranges and their validation)
#   bash verify/mutants.sh render-direct                    (the lines of the renderer's lights,
#                                                            integrator and scene that the direct
#                                                            light's control variate changed)
#   bash verify/mutants.sh wf-slab                          (the lines of src/cache/wf that moving
#                                                            the nodes into a slab at the frame's
#                                                            close changed)
#   bash verify/mutants.sh summary SCOPE                    (rewrite SCOPE's summary.md)
#
# Each scope runs as a cascade: every mutant is first tested against the fastest suite that can
# catch it; only the mutants that survive go on (`cargo mutants --iterate`) to the next, slower
# suite. A mutant is "missed" only if it survives every stage of its scope. The suites are the
# ordinary ones, built in `cargo test`'s own profile (opt-level 1), so the dependencies CI and
# `cargo test` already built are reused; nothing runs that CI does not also run.
#
# Output: results/mutants/<scope>/ holds cargo-mutants' own files (caught.txt, missed.txt,
# timeout.txt, unviable.txt, outcomes.json) of the last stage, with every stage's results
# accumulated, plus summary.md: the commands, the commit, the counts. The equivalent mutants,
# argued one line each, are in docs/verification.md ("Mutation testing").
#
# Time on the 2-core CI machine: wf about 2 hours (287 mutants), ic about 15 min, lincheck under an hour, cache
# about 45 min (a mutant costs a 2-30 s incremental build plus its suite; the core is its own
# package, about 4 s a mutant for the cache scope's first stage). CI does not run this.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
version=27.1.0
if ! cargo mutants --version 2>/dev/null | grep -q "$version"; then
    cargo install cargo-mutants --locked --version "$version"
fi

common=(--in-place --no-shuffle --minimum-test-timeout 20)
real_thread_suites=(--lib --test agreement --test stress --test robustness --test leaks --test wf_api
    --test lookup_work --test removal --test removal_stress)
# The same integration suites by name, for `targets`.
real_thread_tests=(agreement stress robustness leaks wf_api lookup_work removal removal_stress)

# `WFIC_MUTANTS_RESUME=1` keeps the scope's results and runs every stage again with `--iterate`,
# on the mutants the earlier stages left alive only (after adding a test: the fast stage first,
# so a new unit test kills its mutants in seconds). A mutant an earlier stage timed out on is not
# tested again: it already counts as caught, and `--iterate` would retest it, at the cost of a
# whole timeout each time it hangs a later stage's suite.
resume=${WFIC_MUTANTS_RESUME:-0}
# `WFIC_MUTANTS_FROM=N` runs the scope's stages from the Nth on, over the results of those before
# (kept in results/mutants/SCOPE, with the last one's in mutants.out: a stage that failed to start
# moved them to mutants.out.old), to go on after a stage failed to start.
from=${WFIC_MUTANTS_FROM:-1}
stage_no=0

# stage SCOPE FIRST? [cargo-mutants options...] -- [cargo test options...]
stage() {
    local scope=$1 first=$2
    shift 2
    stage_no=$((stage_no + 1))
    if [ "$stage_no" -lt "$from" ]; then return 0; fi
    if [ "$stage_no" -gt 1 ] && [ "$stage_no" = "$from" ]; then first=no; fi
    local out="$root/results/mutants/$scope"
    mkdir -p "$out"
    local iterate=()
    if [ "$first" = no ] || [ "$resume" = 1 ]; then iterate=(--iterate); fi
    # What commands.txt shows of the options: the exclusion by its meaning, not its regex.
    local shown=("${iterate[@]}")
    if [ "$resume" = 1 ]; then
        local hung
        hung=$(timed_out "$out")
        if [ -n "$hung" ]; then
            iterate+=(--exclude-re "$hung")
            shown+=(--exclude-re "'<the $(cat "$out"/stage-*/timeout.txt | sort -u | wc -l) mutants earlier stages timed out on>'")
        fi
    fi
    echo "== mutants $scope: cargo mutants ${common[*]} ${shown[*]} $* (at $(git rev-parse --short HEAD))" |
        tee -a "$out/commands.txt"
    # Exit status 2 means "some mutants were missed", 3 "some timed out": results, not errors.
    cargo mutants "${common[@]}" "${iterate[@]}" -o "$out" "$@" || {
        status=$?
        if [ "$status" != 2 ] && [ "$status" != 3 ]; then exit "$status"; fi
    }
    # Keep each stage's own lists: the next stage's `--iterate` folds them into one file.
    local n=$(($(ls -d "$out"/stage-* 2>/dev/null | wc -l) + 1))
    mkdir -p "$out/stage-$n"
    cp "$out"/mutants.out/*.txt "$out"/mutants.out/outcomes.json "$out/stage-$n/"
}

# timed_out DIR: one regular expression matching exactly the mutants any earlier stage of DIR
# timed out on (their names, metacharacters escaped, anchored), or nothing if there are none.
timed_out() {
    cat "$1"/stage-*/timeout.txt 2>/dev/null | sort -u | python3 -c '
import sys
names = [l.strip() for l in sys.stdin if l.strip()]
meta = set("\\.+*?()|[]{}^$#&-~")
esc = lambda n: "".join("\\" + c if c in meta else c for c in n)
print("^(" + "|".join(esc(n) for n in names) + ")$" if names else "")'
}

# cargo-mutants 27.1.0 runs its baseline (the suite on the unmutated tree, which also sets the
# timeout) over the mutated package's tests only, even under `--test-workspace true` (`lab.rs`,
# `run_baseline`): a stage whose suite lives in another package of the workspace fails there ("no
# test target named `render` in `wfic-render`"). Such a stage skips that baseline and runs its own:
# `workspace_baseline CARGO-TEST-ARGS...` runs the suite unmutated, stops the scope if it fails,
# and prints the options `--baseline=skip --timeout T`, T five times the suite's time (at least
# 60 s), as cargo-mutants sets it. The suite is named with `--cargo-arg` (`targets`): named after
# `--`, a mutant's build built every test target of the workspace (30 s a mutant for the MPI suite).
workspace_baseline() {
    local t0 t1
    # The stage this baseline is for is skipped (`WFIC_MUTANTS_FROM`): nothing to run.
    if [ $((stage_no + 1)) -lt "$from" ]; then
        echo "--baseline=skip"
        return 0
    fi
    cargo test --workspace --no-run "$@" >&2
    t0=$(date +%s)
    cargo test --workspace "$@" >&2 || { echo "the unmutated suite failed: cargo test --workspace $*" >&2; exit 1; }
    t1=$(date +%s)
    local t=$(((t1 - t0) * 5))
    [ "$t" -ge 60 ] || t=60
    echo "--baseline=skip --timeout $t"
}

# `--cargo-arg=--test --cargo-arg=NAME` for each test target named.
targets() {
    local t
    for t in "$@"; do printf -- '--cargo-arg=--test --cargo-arg=%s ' "$t"; done
}

summary() {
    local scope=$1 filter=$2
    # The mutants the scope has now (a code change between stages moves line numbers, so the
    # first stage's count can be stale).
    local re=()
    if [ "$scope" = wf-lookup ]; then re=(--re "$wf_lookup_re"); fi
    if [ "$scope" = wf-removal ]; then re=(--re "$wf_removal_re"); fi
    if [ -f "$root/results/mutants/$scope/diff.patch" ]; then
        re=(--in-diff "$root/results/mutants/$scope/diff.patch")
    fi
    # shellcheck disable=SC2046
    cargo mutants --list -f "$filter" "${re[@]}" $(list_args_of "$scope") > "$root/results/mutants/$scope/mutants-now.txt"
    python3 - "$root/results/mutants/$scope" "$(git rev-parse HEAD)" "$version" <<'PY'
import pathlib, sys, datetime
out, commit, version = pathlib.Path(sys.argv[1]), sys.argv[2], sys.argv[3]
def lines(p):
    return [l for l in p.read_text().splitlines() if l.strip()] if p.exists() else []
stages = sorted(out.glob("stage-*"), key=lambda p: int(p.name.split("-")[1]))
now = set(lines(out / "mutants-now.txt"))
total = len(now)
unviable = set().union(*(lines(st / "unviable.txt") for st in stages)) & now
# `--iterate` retests a mutant that timed out, so one that hung a stage's suite (detected: the
# suite never passes) can be listed as missed by a later stage whose suites do not reach it. Each
# mutant counts once: caught if a stage caught it, else timeout if a stage hung on it, else missed
# if it survived the last stage.
caught_any = set().union(*(lines(st / "caught.txt") for st in stages)) & now
timeouts = sorted(set().union(*(lines(st / "timeout.txt") for st in stages)) & now - caught_any)
last = stages[-1]
missed = [m for m in lines(last / "missed.txt") if m in now and m not in timeouts]
viable = total - len(unviable)
rows = [(k, len(set(lines(st / "caught.txt")) & now)) for k, st in enumerate(stages, 1)]
caught = viable - len(missed) - len(timeouts)
other = caught - sum(c for _, c in rows)
commands = (out / "commands.txt").read_text().splitlines()
md = [f"# Mutation testing: {out.name}", "",
      f"- cargo-mutants {version}; summary written {datetime.date.today()} at commit {commit}",
      "- stages (each tests only the mutants the previous stages left alive):"]
md += ["  " + str(k) + ". `" + c.split(": ", 1)[1] + "`" for k, c in enumerate(commands, 1)]
md += ["", "| | mutants |", "|---|---:|", f"| generated (at the summary's commit) | {total} |",
       f"| unviable (do not build) | {len(unviable)} |", f"| viable | {viable} |"]
for k, c in rows:
    md.append(f"| caught by stage {k} | {c} |")
if other:
    md.append(f"| caught by a stage's run that was restarted, or under an earlier line number | {other} |")
md += [f"| timeout (counted as caught: the mutant hangs a stage's suite) | {len(timeouts)} |",
       f"| **missed** | **{len(missed)}** |",
       f"| mutation score (caught + timeout) / viable | {100.0 * (caught + len(timeouts)) / max(viable, 1):.1f}% |",
       "", "## Missed", ""]
md += [f"- `{m}`" for m in missed] or ["none"]
if timeouts:
    md += ["", "## Timeouts (the suites of the stage named never finish with the mutant)", ""]
    md += [f"- `{m}` (stage {next(k for k, st in enumerate(stages, 1) if m in lines(st / 'timeout.txt'))})"
           for m in timeouts]
if missed:
    md += ["", "Each missed mutant is argued equivalent in `docs/verification.md` (\"Mutation testing\")."]
(out / "summary.md").write_text("\n".join(md) + "\n")
print("\n".join(md))
PY
}

# The commit before removal (issue 13) began: the *-removal scopes mutate the lines changed since.
removal_base=22179d0
# The commit before removal's work was counted (issue 39): cache-work mutates the lines changed since.
work_base=ac128b0
# The commit before deterministic frames (issue 40): deterministic mutates the lines changed since.
deterministic_base=b4ee339
# The commit before the command line's bounds (issue 44): bounds mutates the lines changed since.
bounds_base=83693a4
# The commit before grown lists were rebuilt as one block (issue 42): wf-compact mutates the lines
# changed since.
compact_base=9e7c548
# The commit before the direct light's control variate (issue 41): render-direct mutates the
# lines changed since.
direct_base=6fbe1b8
# The commit before WF's nodes were moved into a slab at the frame's close (issue 42): wf-slab
# mutates the lines changed since.
slab_base=3a44454
# diff_of SCOPE: the --in-diff options of a *-removal scope (the diff is kept beside its results).
diff_of() {
    local scope=$1 out="$root/results/mutants/$1"
    case $scope in
        cache-removal) git diff "$removal_base" -- 'src/cache/*.rs' > "$out/diff.patch" ;;
        ic-removal) git diff "$removal_base" -- src/ic > "$out/diff.patch" ;;
        lincheck-removal) git diff "$removal_base" -- src/research/lincheck > "$out/diff.patch" ;;
        cache-work) git diff "$work_base" -- 'src/cache/*.rs' > "$out/diff.patch" ;;
        deterministic) git diff "$deterministic_base" -- src/cache src/ic > "$out/diff.patch" ;;
        bounds) git diff "$bounds_base" -- src/cache > "$out/diff.patch" ;;
        wf-compact) git diff "$compact_base" -- src/cache/wf > "$out/diff.patch" ;;
        wf-slab) git diff "$slab_base" -- src/cache/wf > "$out/diff.patch" ;;
        render-direct)
            git diff "$direct_base" -- crates/render/src/lights.rs crates/render/src/integrator.rs \
                crates/render/src/scene.rs > "$out/diff.patch"
            ;;
        *) return 0 ;;
    esac
    echo --in-diff "$out/diff.patch"
}

wf_removal_re='remove|compact|reserved|take|capacity|visit|scan|reclaim|prune|end_frame'
wf_lookup_re='mark|walk|directory|scan|cold|tail|push_keyed|segment_layout|new_segment|free_segment|WaitFree<O>::key|Directory'

filter_of() {
    case $1 in
        wf) echo 'src/cache/wf/**' ;;
        cache) echo 'src/cache/*.rs' ;;
        wf-lookup) echo 'src/cache/wf/**' ;;
        wf-removal | wf-compact | wf-slab) echo 'src/cache/wf/**' ;;
        cache-lookup) echo 'src/cache/{octree,sequential}.rs' ;;
        cache-removal | cache-work) echo 'src/cache/*.rs' ;;
        deterministic) echo 'src/**' ;;
        bounds) echo 'src/cache/*.rs' ;;
        render-limits) echo 'crates/render/src/{limits,settings}.rs' ;;
        ic | ic-removal) echo 'src/ic/**' ;;
        lincheck | lincheck-removal) echo 'src/research/lincheck/**' ;;
        render-tiles) echo 'crates/render/src/parallel.rs' ;;
        render-distributed) echo 'crates/render/src/distributed.rs' ;;
        render-direct) echo 'crates/render/src/{lights,integrator,scene}.rs' ;;
    esac
}

# The further options a scope's mutant list needs (the renderer is another package of the workspace).
list_args_of() {
    case $1 in
        render-tiles) echo --workspace -f crates/render/src/work.rs ;;
        render-limits) echo --workspace -f crates/render/src/settings.rs ;;
        render-distributed) echo --workspace --features mpi ;;
        render-direct) echo --workspace ;;
    esac
}

run_scope() {
    local scope=$1
    case $scope in
        render-*)
            # The renderer's scopes build in release (their suites render real images). Release is
            # not incremental by default, so every mutant recompiled the whole renderer (20-45 s);
            # incremental, a mutant recompiles the code generation units its change touches (about
            # 2 s measured on distributed.rs). Only the build's reuse differs, not the code tested.
            export CARGO_PROFILE_RELEASE_INCREMENTAL=true
            ;;
    esac
    local filter
    filter=$(filter_of "$scope")
    [ "$resume" = 1 ] || [ "$from" -gt 1 ] || rm -rf "$root/results/mutants/$scope"
    mkdir -p "$root/results/mutants/$scope"
    local d
    # shellcheck disable=SC2207
    d=($(diff_of "$scope"))
    case $scope in
        wf)
            # The unit tests first (seconds a mutant: they pin the list's rule, the mask and the
            # frame protocol), then loom's hand-written models, then the real-thread suites with
            # the memory page's check, then the exhaustive client's CI subset (minutes a mutant:
            # only for what every other suite left alive). As in the cache scope, the targets are
            # named with `--cargo-arg`, so a mutant builds only the suites its stage runs (named
            # after `--`, every test target of the package was built for each mutant: 15-100 s).
            local f=(-f 'src/cache/wf/**' --no-default-features)
            stage wf yes "${f[@]}" --cargo-arg=--lib
            stage wf no "${f[@]}" --features loom $(targets loom_wf loom_orderings loom_leaks)
            stage wf no "${f[@]}" --cargo-arg=--lib $(targets "${real_thread_tests[@]}" memory)
            stage wf no "${f[@]}" --features loom $(targets loom_client)
            ;;
        wf-lookup)
            # The functions of src/cache/wf that the lean read path added or rewrote (the mask and
            # its helping, the walk, the directory, the scan, the segments' hot and cold halves),
            # through the wf scope's stages: for a quick rerun when the whole scope does not fit.
            stage wf-lookup yes -f 'src/cache/wf/**' --re "$wf_lookup_re" --features loom -- --test loom_wf --test loom_orderings --test loom_leaks
            stage wf-lookup no -f 'src/cache/wf/**' --re "$wf_lookup_re" -- "${real_thread_suites[@]}"
            ;;
        wf-removal)
            # The functions of src/cache/wf that removal (issue 13) added or changed (the slot
            # state, the scan's visitor, removal, compaction, reclamation, the frame's close),
            # through the wf scope's stages.
            stage wf-removal yes -f 'src/cache/wf/**' --re "$wf_removal_re" --features loom -- --test loom_wf --test loom_orderings --test loom_leaks
            stage wf-removal no -f 'src/cache/wf/**' --re "$wf_removal_re" -- "${real_thread_suites[@]}"
            ;;
        wf-compact | wf-slab)
            # The lines of src/cache/wf that a change to the frame's close made: for wf-compact the
            # rebuild of grown lists (the first block's length, the rule, the handle's notes, the
            # close), for wf-slab the move of the nodes into a slab (the node's flag, freeing,
            # the handle's count, the rule, the move). The unit tests that pin the rule first,
            # then the wf scope's stages, with the memory page's check last.
            local f=(-f 'src/cache/wf/**' "${d[@]}")
            stage "$scope" yes "${f[@]}" -- --lib
            stage "$scope" no "${f[@]}" --features loom -- --test loom_wf --test loom_orderings --test loom_leaks
            stage "$scope" no "${f[@]}" -- "${real_thread_suites[@]}" --test memory
            ;;
        cache)
            # Every stage builds the core package alone (cargo-mutants tests the package it
            # mutates; the renderer and the experiments are other packages of the workspace), so
            # a mutant of src/cache rebuilds the caches, the maths and the checkers only (about
            # 3 s for the unit tests). `--no-default-features` is kept so that a default feature
            # added to the core later does not slow the scope down. The schemes' own unit tests (frame
            # protocol, scheme list, octree geometry, the layer's plain types) run in under a
            # second: they go first. The loom models next, then the real-thread suites, and the
            # stress suite (a minute a mutant) last, for whatever is still alive.
            # The targets are named with `--cargo-arg` (given to the build as well as the test
            # run), not after `--` (the test run only), so a mutant builds only what its stage runs.
            stage cache yes -f 'src/cache/*.rs' --no-default-features --cargo-arg=--lib
            stage cache no -f 'src/cache/*.rs' --no-default-features --features loom \
                $(targets loom_lck_lw loom_wf)
            stage cache no -f 'src/cache/*.rs' --no-default-features \
                $(targets agreement robustness leaks wf_api lookup_work lincheck removal lincheck_removal)
            stage cache no -f 'src/cache/*.rs' --no-default-features $(targets stress removal_stress)
            ;;
        cache-lookup)
            # The files of src/cache/*.rs that the lean read path rewrote (the geometry and the
            # plain octree), through the cache scope's stages: for a quick rerun after a change
            # to them, when the whole cache scope (45 minutes) does not fit.
            local f=(-f src/cache/octree.rs -f src/cache/sequential.rs)
            stage cache-lookup yes "${f[@]}" --no-default-features --cargo-arg=--lib
            stage cache-lookup no "${f[@]}" --no-default-features --features loom \
                $(targets loom_lck_lw loom_wf)
            stage cache-lookup no "${f[@]}" --no-default-features \
                $(targets agreement robustness leaks wf_api lookup_work lincheck)
            stage cache-lookup no "${f[@]}" --no-default-features $(targets stress)
            ;;
        cache-removal | cache-work)
            # The lines of src/cache/*.rs that removal (or the counting of its work) changed,
            # through the cache scope's stages.
            stage "$scope" yes -f 'src/cache/*.rs' "${d[@]}" --no-default-features --cargo-arg=--lib
            stage "$scope" no -f 'src/cache/*.rs' "${d[@]}" --no-default-features --features loom \
                $(targets loom_lck_lw loom_wf)
            stage "$scope" no -f 'src/cache/*.rs' "${d[@]}" --no-default-features \
                $(targets agreement robustness leaks wf_api lookup_work lincheck removal lincheck_removal)
            stage "$scope" no -f 'src/cache/*.rs' "${d[@]}" --no-default-features $(targets stress removal_stress)
            ;;
        deterministic)
            # The lines deterministic frames added or changed in src/cache and src/ic (the
            # visibility rule, the ordered sum, the tile runner, the ledger's set, every
            # backend's lookup_visible): the unit tests, then the property and the agreement
            # suites, then the loom models.
            local f=(-f 'src/**' "${d[@]}")
            stage "$scope" yes "${f[@]}" --features rayon --cargo-arg=--lib
            stage "$scope" no "${f[@]}" --features rayon $(targets deterministic agreement robustness)
            stage "$scope" no "${f[@]}" --features loom $(targets loom_deterministic loom_wf)
            ;;
        ic | ic-removal)
            # The maths' unit tests also run under the checker features, where the crate is small.
            stage "$scope" yes -f 'src/ic/**' "${d[@]}" --features loom -- --lib
            stage "$scope" no -f 'src/ic/**' "${d[@]}" -- --lib --test agreement --test robustness --test removal
            ;;
        lincheck | lincheck-removal)
            stage "$scope" yes -f 'src/research/lincheck/**' "${d[@]}" --features shuttle -- --lib
            # The lib's checker tests ran in stage 1 (they are the same under shuttle): only the
            # real-thread suite is new here, and leaving --lib out saves a second crate build.
            stage "$scope" no -f 'src/research/lincheck/**' "${d[@]}" -- --test lincheck --test lincheck_removal
            # What only the loom build compiles (a full model list's refusal).
            stage "$scope" no -f 'src/research/lincheck/**' "${d[@]}" --features loom -- --lib
            ;;
        render-tiles)
            # The tile loop (`parallel.rs`) and the one work source behind every way of rendering
            # tiles (`work.rs`): the renderer's unit tests first, then the renderer suite, which
            # renders every scene with every scheme against the reference. Release: the suite
            # renders real images.
            local f=(--workspace -f crates/render/src/parallel.rs -f crates/render/src/work.rs)
            stage "$scope" yes "${f[@]}" --test-package wfic-render --cargo-arg=--release --cargo-arg=--lib
            local b
            b=$(workspace_baseline --release --test render)
            # shellcheck disable=SC2086
            stage "$scope" no "${f[@]}" --test-workspace true $b --cargo-arg=--release $(targets render)
            ;;
        bounds)
            # The lines of src/cache the command line's bounds changed (the accuracy's bound as a
            # constant, `Frame::run`'s thread bound and its spawning): the unit tests.
            stage "$scope" yes -f 'src/cache/*.rs' "${d[@]}" --no-default-features --cargo-arg=--lib
            ;;
        render-limits)
            # The renderer's ranges and `RenderSettings::validate`: its unit tests, then the
            # command line's property test, which runs every option at its edges.
            local f=(--workspace -f crates/render/src/limits.rs -f crates/render/src/settings.rs)
            stage "$scope" yes "${f[@]}" --test-package wfic-render --cargo-arg=--lib
            # The test target is named after `--` (the test run only). `--test-workspace true`
            # rather than `--test-package wfic-experiments`: cargo-mutants 27.1.0 ran the mutated
            # package's own tests with the latter ("no test target named `command_line` in
            # `wfic-render`"); `cargo test --workspace --test NAME` finds the target in the
            # package that has it.
            local b
            b=$(workspace_baseline --test command_line)
            # shellcheck disable=SC2086
            stage "$scope" no "${f[@]}" --test-workspace true $b -- --test command_line
            ;;
        render-distributed)
            # The MPI exchange: its unit tests, then the suite that runs `mpirun -np 2` and 3 and
            # compares the images and the records sent, received and inserted.
            local f=(--workspace -f crates/render/src/distributed.rs --features mpi)
            stage "$scope" yes "${f[@]}" --test-package wfic-render --cargo-arg=--release --cargo-arg=--lib
            local b
            b=$(workspace_baseline --release --features mpi --test mpi)
            # shellcheck disable=SC2086
            stage "$scope" no "${f[@]}" --test-workspace true $b --cargo-arg=--release $(targets mpi)
            ;;
        render-direct)
            # The direct light's control variate: the renderer's unit tests (the estimators
            # against exact and brute-force integrals), then the experiments' `reproduce` suite,
            # whose `direct` test checks the variance the control removes on the Cornell box.
            local f=(--workspace -f crates/render/src/lights.rs -f crates/render/src/integrator.rs
                -f crates/render/src/scene.rs "${d[@]}")
            stage "$scope" yes "${f[@]}" --test-package wfic-render --cargo-arg=--release --cargo-arg=--lib
            local b
            b=$(workspace_baseline --release --test reproduce)
            # shellcheck disable=SC2086
            stage "$scope" no "${f[@]}" --test-workspace true $b --cargo-arg=--release $(targets reproduce)
            ;;
        *)
            echo "unknown scope $scope (wf, cache, ic, lincheck, render-tiles, render-distributed or all)" >&2
            exit 64
            ;;
    esac
    summary "$scope" "$filter"
}

if [ "${1:-}" = summary ]; then
    # `bash verify/mutants.sh summary SCOPE`: rewrite the summary from the stages already run.
    summary "$2" "$(filter_of "$2")"
elif [ "${1:-all}" = all ]; then
    for s in wf cache ic lincheck; do run_scope "$s"; done
else
    run_scope "$1"
fi
