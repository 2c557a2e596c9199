//! Memory per record (issue 42, point 2): every caching scheme filled with 10^3 to 10^6 records of
//! the benches' scene-like workload, its heap counted by this binary's global allocator, split
//! into nodes, list segments, keys and records, and set beside Radiance's ambient record.
//!
//! `cargo run --release --example memory` writes `results/memory/README.md` and
//! `results/memory/memory.csv`; `-- --quick` stops at 10^5 and only prints; `-- --out-dir DIR`
//! writes there instead. What is counted and how it is attributed: `measure.rs`.

#[path = "../../benches/common/mod.rs"]
mod common;
mod measure;
#[path = "../../verify/tree_shape.rs"]
mod tree_shape;

use measure::*;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::Command;
use wfic::cache::{CacheConfig, Scheme};
use wfic::ic::{Key, Record};

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The workload's records are drawn from this stream (any seed gives the same picture).
const SEED: u64 = 0x0422;

/// One measured row: a scheme at one size, with its attribution.
struct Row {
    measured: Measured,
    split: Split,
}

/// Radiance's model at one size.
struct RadianceRow {
    n: u64,
    groups: u64,
    requested: u64,
    chunks: u64,
}

/// One size: every scheme, Radiance's model, and the WF lists' shape.
struct Size {
    n: usize,
    rows: Vec<Row>,
    radiance: RadianceRow,
    lists: u64,
    mean_list: f64,
    /// WF's spare slot bytes under each of [`POLICIES`].
    policies: Vec<u64>,
    /// WF's lists by the blocks they hold after the frame's close: (segments grown, 0 for a list
    /// rebuilt as one block; lists, records, spare bytes).
    by_segments: Vec<(u32, u64, u64, u64)>,
}

/// WF's lists grouped by how many segments each holds after the frame's close (0: rebuilt as one
/// block).
fn by_segments(shape: &tree_shape::TreeShape) -> Vec<(u32, u64, u64, u64)> {
    let mut groups: Vec<(u32, u64, u64, u64)> = Vec::new();
    for len in shape.list_lengths().filter(|&len| len > 0) {
        let capacity = wf_capacity(len);
        // Capacities 4, 12, 28, ...: 4 (2^s - 1) for s segments.
        let segments = if wf_rebuilt(len) {
            0
        } else {
            (capacity / WF_FIRST_SEGMENT + 1).trailing_zeros()
        };
        let spare = (capacity - len) * WF_SLOT as u64;
        match groups.iter_mut().find(|g| g.0 == segments) {
            Some(g) => {
                g.1 += 1;
                g.2 += len;
                g.3 += spare;
            }
            None => groups.push((segments, 1, len, spare)),
        }
    }
    groups.sort_unstable();
    groups
}

fn run_size(config: CacheConfig, n: usize, fixed: &[(Scheme, u64)]) -> Size {
    let records = common::scene_records(n, SEED);
    let shape = shape(&config, &records);
    let (lists, mean_list) = lists(&shape);
    let policies = POLICIES.iter().map(|p| wf_spare(&shape, p)).collect();
    let by_segments = by_segments(&shape);
    let mut rows = Vec::new();
    for scheme in SCHEMES {
        let measured = measure(scheme, config, &records);
        assert_eq!(measured.stats.records, n, "{scheme}: records stored");
        assert_eq!(
            measured.stats.nodes,
            shape.nodes(),
            "{scheme}: nodes against the tree shape"
        );
        let fixed = fixed.iter().find(|f| f.0 == scheme).expect("fixed").1;
        let split = attribute(scheme, n as u64, &shape, fixed);
        eprintln!(
            "memory: {scheme} n={n}: {} bytes in {} blocks, {:.1} B/record, unattributed {}",
            measured.live.bytes,
            measured.live.blocks,
            measured.bytes_per_record(),
            measured.live.bytes as i64 - split.total() as i64
        );
        rows.push(Row { measured, split });
    }
    let groups = radiance_groups(&config, &records);
    let (requested, chunks) = radiance_bytes(n as u64, groups);
    Size {
        n,
        rows,
        radiance: RadianceRow {
            n: n as u64,
            groups,
            requested,
            chunks,
        },
        lists,
        mean_list,
        policies,
        by_segments,
    }
}

fn main() {
    let mut quick = false;
    let mut out_dir = None;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--quick" => quick = true,
            "--out-dir" => out_dir = Some(PathBuf::from(args.next().expect("--out-dir DIR"))),
            other => panic!("unknown argument {other}: memory [--quick] [--out-dir DIR]"),
        }
    }
    let out_dir = match (out_dir, quick) {
        (Some(dir), _) => Some(dir),
        (None, false) => Some(PathBuf::from("results/memory")),
        (None, true) => None,
    };
    let sizes: &[usize] = if quick {
        &[1_000, 10_000, 100_000]
    } else {
        &[1_000, 10_000, 100_000, 1_000_000]
    };
    let config = common::scene_config();
    // The empty cache after a frame without inserts: the `fixed` part of every attribution.
    let fixed: Vec<(Scheme, u64)> = SCHEMES
        .iter()
        .map(|&s| (s, measure(s, config, &[]).live.bytes))
        .collect();
    let results: Vec<Size> = sizes.iter().map(|&n| run_size(config, n, &fixed)).collect();
    let page = page(&results, quick);
    match out_dir {
        Some(dir) => {
            std::fs::create_dir_all(&dir).expect("create the output directory");
            std::fs::write(dir.join("README.md"), &page).expect("write README.md");
            std::fs::write(dir.join("memory.csv"), csv(&results)).expect("write memory.csv");
            eprintln!("memory: wrote {}", dir.display());
        }
        None => print!("{page}"),
    }
}

/// The CSV: one line per scheme and size, then Radiance's model.
fn csv(results: &[Size]) -> String {
    let mut out = String::from(
        "scheme,n,live_bytes,live_blocks,glibc_chunk_bytes,bytes_per_record,ratio_to_record_and_key,\
         nodes,lists,records,keys,slot_extra,spare,node_bytes,index,fixed,unattributed\n",
    );
    for size in results {
        for row in &size.rows {
            let (m, s) = (&row.measured, &row.split);
            writeln!(
                out,
                "{},{},{},{},{},{:.2},{:.4},{},{},{},{},{},{},{},{},{},{}",
                m.scheme.name(),
                m.n,
                m.live.bytes,
                m.live.blocks,
                m.live.chunk_bytes,
                m.bytes_per_record(),
                m.ratio(),
                m.stats.nodes,
                size.lists,
                s.records,
                s.keys,
                s.slot_extra,
                s.spare,
                s.nodes,
                s.index,
                s.fixed,
                m.live.bytes as i64 - s.total() as i64,
            )
            .unwrap();
        }
        let r = &size.radiance;
        writeln!(
            out,
            "radiance-model,{},{},,{},{:.2},{:.4},{},,,,,,,,,",
            r.n,
            r.requested,
            r.chunks,
            r.requested as f64 / r.n as f64,
            r.requested as f64 / r.n as f64 / RECORD_AND_KEY as f64,
            r.groups,
        )
        .unwrap();
    }
    out
}

/// Runs a command and returns its first line of output, or a placeholder.
fn first_line(program: &str, args: &[&str]) -> String {
    Command::new(program)
        .args(args)
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.lines().next().map(str::to_owned))
        .unwrap_or_else(|| format!("({program} unavailable)"))
}

/// The host triple from `rustc -vV` (examples are built for the host).
fn host_triple() -> String {
    Command::new("rustc")
        .arg("-vV")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("host: ").map(str::to_owned))
        })
        .unwrap_or_else(|| format!("{}-{}", std::env::consts::ARCH, std::env::consts::OS))
}

fn per(bytes: u64, n: usize) -> String {
    format!("{:.1}", bytes as f64 / n as f64)
}

/// The generated page.
fn page(results: &[Size], quick: bool) -> String {
    let mut p = String::new();
    let commit = first_line("git", &["rev-parse", "HEAD"]);
    let dirty = !first_line("git", &["status", "--porcelain", "--untracked-files=no"])
        .starts_with('(')
        && !Command::new("git")
            .args(["status", "--porcelain", "--untracked-files=no"])
            .output()
            .map(|o| o.stdout.is_empty())
            .unwrap_or(true);
    let command = if quick {
        "cargo run --release --example memory -- --quick"
    } else {
        "cargo run --release --example memory"
    };
    writeln!(p, "# Memory per record (issue 42, point 2)\n").unwrap();
    writeln!(
        p,
        "Generated by `examples/memory/main.rs`; do not edit by hand. Command: `{command}`.\n"
    )
    .unwrap();
    writeln!(
        p,
        "- commit: `{commit}`{}",
        if dirty {
            " (with uncommitted changes)"
        } else {
            ""
        }
    )
    .unwrap();
    writeln!(
        p,
        "- date: {}",
        first_line("date", &["-u", "+%Y-%m-%d %H:%M UTC"])
    )
    .unwrap();
    writeln!(p, "- compiler: {}", first_line("rustc", &["-V"])).unwrap();
    writeln!(
        p,
        "- target: `{}` (bytes depend on the target's pointer size and alignment, not on the CPU)\n",
        host_triple()
    )
    .unwrap();
    writeln!(
        p,
        "Each scheme's cache is built empty and filled with N records of the benches' scene-like \
         workload (`benches/common`: the room with three boxes, accuracy 0.25, radii 0.05 to \
         0.5; `scene_records(N, {SEED:#x})`), inserted by one handle in one frame on one thread. \
         **Bytes** are the counting allocator's live total (as requested) after the frame closed, \
         minus the total before the cache was built: the cache's heap alone. **Blocks**: live \
         allocations. **glibc est.**: what glibc's malloc would hold for those blocks (size plus \
         its 8-byte header, rounded to 16; large mappings not modelled). The **ratio** is bytes \
         per record over one record and its key, `size_of::<Record>() + size_of::<Key>()` = {} + \
         {} = {RECORD_AND_KEY} bytes: the key is the per-slot `Key` (position, normal, squared \
         reach) every scheme stores beside each record for the prefilter; WF keeps it with the \
         slot's state byte in a 32-byte hot half.\n",
        std::mem::size_of::<Record>(),
        std::mem::size_of::<Key>(),
    )
    .unwrap();
    writeln!(
        p,
        "**The split** is by `size_of` x counts, not measured part by part: the counts are the \
         records' tree shape worked out from the public geometry (`verify/tree_shape.rs`), \
         checked against each cache's `stats()` (records and nodes equal); the sizes are the \
         documented layouts (WF node {WF_NODE} B, WF slot {WF_HOT} + {} B, segments of 4, 8, 16, \
         ... slots, a {WF_DIRECTORY}-byte directory once a list outgrows its first segment, and \
         at the frame's close a list past its second segment with more than a sixteenth unused \
         rebuilt as one block of its length and a sixteenth, without a directory; the \
         arena octree's node {ARENA_NODE} B and `Vec`s doubling from 4). *records* and *keys* \
         are N x {} and N x {}; *slot extra* WF's state byte and padding; *spare* capacity \
         allocated and unused (WF: unreserved slots of allocated segments; arena: `Vec` capacity \
         beyond length); *nodes* the nodes beyond the root; *index* WF's directory pointers and \
         directories; *fixed* the same cache after a frame with no insert. *unattr.* is the \
         measured total minus the split's sum: zero means the split accounts for every byte.\n",
        std::mem::size_of::<Record>(),
        std::mem::size_of::<Record>(),
        std::mem::size_of::<Key>(),
    )
    .unwrap();
    writeln!(
        p,
        "LCK and LCK-RW hold TRA's octree behind a lock, and LW's global octree is TRA's after \
         the merge (the local one is emptied), so their bytes are TRA's. WF-D differs from WF \
         only in what a lost child race does; one thread loses none, so its tree is WF's.\n"
    )
    .unwrap();
    for size in results {
        size_table(&mut p, size);
    }
    radiance_section(&mut p);
    if let Some(last) = results.last() {
        where_wf_bytes_go(&mut p, last);
    }
    verdict(&mut p, results);
    p
}

/// One size's table: every scheme, then Radiance's model.
fn size_table(p: &mut String, size: &Size) {
    writeln!(
        p,
        "## N = {} ({} nodes, {} non-empty lists, {:.1} records a list)\n",
        size.n, size.rows[0].measured.stats.nodes, size.lists, size.mean_list
    )
    .unwrap();
    writeln!(
        p,
        "| scheme | bytes | blocks | B/record | ratio | glibc est. B/record | records | keys | slot extra | spare | nodes | index | fixed | unattr. |"
    )
    .unwrap();
    writeln!(
        p,
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )
    .unwrap();
    for row in &size.rows {
        let (m, s) = (&row.measured, &row.split);
        writeln!(
            p,
            "| {} | {} | {} | {:.1} | {:.3} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            m.scheme.heading(),
            m.live.bytes,
            m.live.blocks,
            m.bytes_per_record(),
            m.ratio(),
            per(m.live.chunk_bytes, m.n),
            per(s.records, m.n),
            per(s.keys, m.n),
            per(s.slot_extra, m.n),
            per(s.spare, m.n),
            per(s.nodes, m.n),
            per(s.index, m.n),
            per(s.fixed, m.n),
            m.live.bytes as i64 - s.total() as i64,
        )
        .unwrap();
    }
    let r = &size.radiance;
    writeln!(
        p,
        "| Radiance (model) | {} | | {:.1} | {:.3} | {} | {} | | | | {} | | | |\n",
        r.requested,
        r.requested as f64 / r.n as f64,
        r.requested as f64 / r.n as f64 / RECORD_AND_KEY as f64,
        per(r.chunks, size.n),
        per(r.n * RADIANCE_AVSIZE as u64, size.n),
        per(r.requested - r.n * RADIANCE_AVSIZE as u64, size.n),
    )
    .unwrap();
    writeln!(
        p,
        "Per-record columns are bytes per record; *bytes* and *unattr.* are totals. \
         Radiance's row: its *records* column is `AVSIZE` per record, its *nodes* column \
         the pool blocks of its {} child groups.\n",
        r.groups
    )
    .unwrap();
}

/// What Radiance's record is, and what the model assumes.
fn radiance_section(p: &mut String) {
    writeln!(p, "## Radiance's ambient record\n").unwrap();
    writeln!(
        p,
        "`AMBVAL` (`struct ambrec` in `src/rt/ambient.h` of LBNL-ETA/Radiance, commit bcffc2b5) \
         mirrored field for field as a `repr(C)` struct (`examples/memory/measure.rs`): a next \
         pointer, `float pos[3]`, `int32 ndir, udir`, `short lvl` (then 2 bytes of padding), \
         `float weight`, `float rad[2], gpos[2], gdir[2]`, `uint32 corral`, and `SCOLOR val` \
         last. `SCOLOR` is `float[MAXCSAMP]` with `MAXCSAMP` = {RADIANCE_MAXCSAMP} in that tree \
         (`src/common/color.h`), so `sizeof(AMBVAL)` = **{RADIANCE_AMBVAL} bytes** on x86-64. \
         Radiance never allocates that much: `newambval()` mallocs `AVSIZE` = `sizeof(AMBVAL) - \
         sizeof(SCOLOR) + sizeof(COLORV) * NCSAMP` (`src/rt/ambient.c`), and `NCSAMP` is 3 by \
         default (`CNDX[3]` in `src/common/color.c`): **{RADIANCE_AVSIZE} bytes** per record, \
         one malloc each ({} bytes as a glibc chunk). The record carries its own list link \
         (`next`), so a node's list costs nothing beyond it.\n",
        glibc_chunk(RADIANCE_AVSIZE)
    )
    .unwrap();
    writeln!(
        p,
        "Its octree, `AMBTREE`, is a record-list head and a pointer to eight children that are \
         allocated together ({RADIANCE_KIDS} bytes, zeroed, the first time `avinsert` descends \
         through a node), taken from pool blocks of 512 such groups (64 KiB) that are never \
         returned to malloc; the trunk is a static. What is known: those sizes, and the rule \
         `avinsert` descends by (while `s * OCTSCALE / 2 > rad[1] * ambacc`, `OCTSCALE` = 1, \
         `s` the node's cube size). What is assumed for the *Radiance (model)* rows: that \
         `rad[1] * ambacc` is this workload's `a R` and that the scene cube is the cache's root \
         cube; the child groups are then counted by replaying that rule on the same records. \
         Radiance's record holds less than ours (no gradients per channel, no id or check, an \
         encoded normal), so the rows compare what each design spends around its record, not \
         like with like.\n"
    )
    .unwrap();
}

/// WF's bytes at the largest N: its lists by segments allocated, and the spare capacity other
/// growth policies would leave (a model on the same lists).
fn where_wf_bytes_go(p: &mut String, size: &Size) {
    let wf = size
        .rows
        .iter()
        .find(|r| r.measured.scheme == Scheme::Wf)
        .expect("a WF row");
    let n = size.n;
    writeln!(
        p,
        "## Where WF's bytes go at N = {n}
"
    )
    .unwrap();
    writeln!(
        p,
        "Per record, WF's floor is its slot ({WF_HOT} + {} B) and its share of the nodes and \
         directories; the rest is *spare*: slots of allocated blocks that no record uses. During \
         a frame a list of `len` records holds segments of 4, 8, 16, ... slots up to the one \
         `len` reaches, so after its last doubling up to half its slots are empty. When the \
         frame closes, a list that opened a third segment, with more than a sixteenth of its \
         slots unused, is rebuilt as one block of `len` slots and a sixteenth \
         (`src/cache/wf/list.rs`, 5). The lists after the close, by segments held (*one block*: \
         rebuilt):
",
        std::mem::size_of::<Record>()
    )
    .unwrap();
    writeln!(
        p,
        "| segments | slots | lists | records | spare B | spare B/record (all N) |"
    )
    .unwrap();
    writeln!(p, "|---:|---:|---:|---:|---:|---:|").unwrap();
    for &(segments, lists, records, spare) in &size.by_segments {
        let (segments, slots) = if segments == 0 {
            (
                "one block".to_string(),
                (records + spare / WF_SLOT as u64).to_string(),
            )
        } else {
            (
                segments.to_string(),
                (WF_FIRST_SEGMENT * ((1 << segments) - 1)).to_string(),
            )
        };
        writeln!(
            p,
            "| {segments} | {slots} | {lists} | {records} | {spare} | {} |",
            per(spare, n)
        )
        .unwrap();
    }
    writeln!(
        p,
        "\nThe same lists under other growth policies (spare recomputed, everything else, the \
         directories too, as measured; a model, not a build). A policy whose segments stop \
         doubling needs a directory that grows with the list (49 entries then no longer cover \
         any address space), a pointer a segment; that is not in these figures:\n"
    )
    .unwrap();
    writeln!(p, "| policy | spare B/record | total B/record | ratio |").unwrap();
    writeln!(p, "|---|---:|---:|---:|").unwrap();
    for (policy, &spare) in POLICIES.iter().zip(&size.policies) {
        let total = wf.measured.live.bytes - wf.split.spare + spare;
        writeln!(
            p,
            "| {} | {} | {} | {:.3} |",
            policy.name,
            per(spare, n),
            per(total, n),
            total as f64 / n as f64 / RECORD_AND_KEY as f64
        )
        .unwrap();
    }
    writeln!(p).unwrap();
}

/// The one-line verdict on the goal, from the largest WF row.
fn verdict(p: &mut String, results: &[Size]) {
    let Some(last) = results.last() else { return };
    let wf = last
        .rows
        .iter()
        .find(|r| r.measured.scheme == Scheme::Wf)
        .expect("a WF row");
    let ratio = wf.measured.ratio();
    writeln!(p, "## Verdict\n").unwrap();
    writeln!(
        p,
        "Goal: WF at most {GOAL_RATIO}x the bytes of a record plus its key ({:.0} B) at 10^6 \
         records. **{}**: WF holds {:.1} B/record at N = {}, {ratio:.3}x.",
        GOAL_RATIO * RECORD_AND_KEY as f64,
        if last.n < 1_000_000 {
            "Not measured at 10^6 (quick run)"
        } else if ratio <= GOAL_RATIO {
            "Met"
        } else {
            "Missed"
        },
        wf.measured.bytes_per_record(),
        last.n,
    )
    .unwrap();
}
