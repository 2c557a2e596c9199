//! The page `results/records-held/README.md` and its CSV, written by a full run.

use super::{Row, Run};
use std::fmt::Write as _;

/// What the page says about the run beside its figures.
pub struct Context {
    date: String,
    load: String,
    /// The busiest other processes: CPU share, nice, name.
    busy: String,
}

fn command(cmd: &str, args: &[&str]) -> String {
    std::process::Command::new(cmd)
        .args(args)
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "?".into())
}

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

/// The CPU's model name (`/proc/cpuinfo`).
pub fn cpu() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

impl Context {
    pub fn now() -> Self {
        Self {
            date: command("date", &["-u", "+%Y-%m-%d %H:%M UTC"]),
            load: loadavg(),
            busy: command("ps", &["-eo", "pcpu=,ni=,comm=", "--sort=-pcpu"])
                .lines()
                .filter(|l| !l.contains("records_held"))
                .take(4)
                .map(|l| {
                    let f: Vec<&str> = l.split_whitespace().collect();
                    format!(
                        "`{}` {}% at nice {}",
                        f.get(2).unwrap_or(&"?"),
                        f[0],
                        f.get(1).unwrap_or(&"?")
                    )
                })
                .collect::<Vec<_>>()
                .join(", "),
        }
    }
}

/// Least-squares slope of `ln y` against `ln x`.
fn slope(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let (lx, ly): (Vec<f64>, Vec<f64>) = points.iter().map(|&(x, y)| (x.ln(), y.ln())).unzip();
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx) * (x - mx)).sum();
    Some(sxy / sxx)
}

fn ward(rows: &[Row]) -> impl Iterator<Item = &Row> {
    rows.iter().filter(|r| r.kind == "ward")
}

/// A scheme's `(records, ns)` points over the Ward sets, for lookups or inserts (TRA's taken from
/// the WF pair, else the first pair).
fn series(rows: &[Row], scheme: &str, insert: bool) -> Vec<(f64, f64)> {
    ward(rows)
        .filter_map(|r| {
            let ns = if scheme == "tra" {
                let p = r
                    .pairs
                    .iter()
                    .find(|p| p.scheme == "wf")
                    .or(r.pairs.first())?;
                if insert {
                    p.tra_insert_ns
                } else {
                    p.tra_lookup_ns
                }
            } else {
                let p = r.pairs.iter().find(|p| p.scheme == scheme)?;
                if insert {
                    p.insert_ns
                } else {
                    p.lookup_ns
                }
            };
            Some((r.records as f64, ns))
        })
        .collect()
}

fn set_name(r: &Row) -> String {
    match r.target {
        Some(t) => format!("ward 10^{}", (t as f64).log10().round()),
        None => r.kind.clone(),
    }
}

/// The accuracy used, and the search's tries before it.
fn accuracy(r: &Row) -> String {
    let before = &r.tried[..r.tried.len().saturating_sub(1)];
    if before.is_empty() {
        format!("{:.5}", r.accuracy)
    } else {
        let tries: Vec<String> = before.iter().map(|a| format!("{a:.5}")).collect();
        format!("{:.5} (tried {})", r.accuracy, tries.join(", "))
    }
}

/// The three tables (sets, lookups, inserts), in Markdown.
pub fn tables(rows: &[Row]) -> String {
    let cpu = cpu();
    let mut s = String::new();
    s.push_str(
        "| set | accuracy | records | samples | nodes | depth | lists | mean list | max list | \
         nodes visited / lookup | records examined / lookup | valid / lookup | hit rate |\n",
    );
    s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {:.1} | {} | {:.1} | {:.1} | {:.2} | {:.1}% |",
            set_name(r),
            accuracy(r),
            r.records,
            r.samples.map_or("-".into(), |n| n.to_string()),
            r.shape.nodes,
            r.shape.depth,
            r.shape.lists,
            r.shape.mean_list,
            r.shape.max_list,
            r.work.nodes,
            r.work.examined,
            r.work.valid,
            100.0 * r.work.hit_rate
        );
    }
    let _ = write!(
        s,
        "\nLookups, one thread, on {cpu}: median ns per lookup over the ABBA rounds, and the \
         median of the per-round ratios with its quartiles; the queries in random order, then the same \
         queries in Morton order (`sorted`).\n\n| set | records | scheme | ns per \
         lookup ({cpu}) | TRA's, same rounds | scheme / TRA | quartiles | sorted: ns | TRA's | \
         scheme / TRA | quartiles |\n|---|---:|---|---:|---:|---:|---|---:|---:|---:|---|\n"
    );
    for r in rows {
        for p in &r.pairs {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.0} | {:.0} | {:.3} | {:.3}–{:.3} | {:.0} | {:.0} | {:.3} | \
                 {:.3}–{:.3} |",
                set_name(r),
                r.records,
                p.scheme,
                p.lookup_ns,
                p.tra_lookup_ns,
                p.ratio.1,
                p.ratio.0,
                p.ratio.2,
                p.sorted_ns,
                p.tra_sorted_ns,
                p.sorted_ratio.1,
                p.sorted_ratio.0,
                p.sorted_ratio.2
            );
        }
    }
    let _ = write!(
        s,
        "\nInserts, one thread, on {cpu}: median ns per insert (the batch and its frame's close) \
         over the rounds, and the median of the per-round ratios. *First batch*: the batch each \
         filled cache takes before the timed one (median ns per insert; what the first frame \
         after a fill pays, the allocator's deferred work of the fill's close included). *Fill*: \
         ns per record to fill an empty cache with the set in one frame, its close included \
         (WF's close moves the tree into its slab), one fill each.\n\n| set | records | scheme | \
         ns per insert ({cpu}) | TRA's, same rounds | scheme / TRA | quartiles | first batch | \
         TRA's first batch | fill | TRA's fill |\n|---|---:|---|---:|---:|---:|---|---:|---:|---:|---:|\n"
    );
    for r in rows {
        for p in &r.pairs {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.0} | {:.0} | {:.3} | {:.3}–{:.3} | {:.0} | {:.0} | {:.0} | {:.0} |",
                set_name(r),
                r.records,
                p.scheme,
                p.insert_ns,
                p.tra_insert_ns,
                p.insert_ratio.1,
                p.insert_ratio.0,
                p.insert_ratio.2,
                p.first_ns,
                p.tra_first_ns,
                p.fill_ns,
                p.tra_fill_ns
            );
        }
    }
    s
}

/// The fitted slopes, in Markdown.
fn growth(rows: &[Row]) -> String {
    let mut s = String::from(
        "| scheme | lookup: slope of ln(ns) on ln(records) | insert: slope |\n|---|---:|---:|\n",
    );
    for scheme in ["tra", "wf", "lck", "lw"] {
        let (l, i) = (
            slope(&series(rows, scheme, false)),
            slope(&series(rows, scheme, true)),
        );
        let f = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3}"));
        if l.is_some() || i.is_some() {
            let _ = writeln!(s, "| {scheme} | {} | {} |", f(l), f(i));
        }
    }
    s
}

/// The two goals' verdicts, in Markdown.
fn goals(rows: &[Row]) -> String {
    let mut s = String::new();
    let wf = series(rows, "wf", false);
    let tra = series(rows, "tra", false);
    let at = |v: &[(f64, f64)], n: f64| {
        v.iter()
            .find(|&&(x, _)| (x / n).log10().abs() < 0.2)
            .map(|&(_, y)| y)
    };
    match (at(&wf, 1e4), at(&wf, 1e7)) {
        (Some(a), Some(b)) => {
            let (ta, tb) = (
                at(&tra, 1e4).unwrap_or(f64::NAN),
                at(&tra, 1e7).unwrap_or(f64::NAN),
            );
            let _ = writeln!(
                s,
                "- **Goal 1, WF's lookup at 10^7 records at most 1.5x its lookup at 10^4: {}.** \
                 {b:.0} ns against {a:.0} ns, {:.2}x (TRA in the same rounds: {tb:.0} against \
                 {ta:.0} ns, {:.2}x). The two figures come from runs minutes apart, so they carry \
                 the machine's drift, which the ABBA ratios do not.",
                if b / a <= 1.5 { "met" } else { "missed" },
                b / a,
                tb / ta
            );
        }
        _ => s.push_str("- Goal 1: not measured (no Ward set near 10^4 or 10^7 records).\n"),
    }
    let mut misses = Vec::new();
    let mut worst = 0.0f64;
    for r in rows {
        if let Some(p) = r.pairs.iter().find(|p| p.scheme == "wf") {
            worst = worst.max(p.ratio.1);
            if p.ratio.1 > 1.02 {
                misses.push(format!("{} ({:.3})", set_name(r), p.ratio.1));
            }
        }
    }
    let _ = writeln!(
        s,
        "- **Goal 2, WF/TRA at or below 1.02 at every size: {}.** The largest median is {worst:.3}{}.",
        if misses.is_empty() { "met" } else { "missed" },
        if misses.is_empty() {
            String::new()
        } else {
            format!("; above 1.02: {}", misses.join(", "))
        }
    );
    s
}

/// Where a lookup's time goes, per set: the work (depth, nodes visited, records examined) beside
/// the time per node visited, and what putting the same queries in Morton order saves.
fn where_time_goes(rows: &[Row]) -> String {
    let mut s = String::from(
        "| set | records | depth | nodes visited / lookup | examined / lookup | mean list | \
         TRA ns / node visited | WF ns / node visited | TRA random / sorted | WF random / sorted |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let Some(p) = r.pairs.iter().find(|p| p.scheme == "wf") else {
            continue;
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.2} | {:.2} |",
            set_name(r),
            r.records,
            r.shape.depth,
            r.work.nodes,
            r.work.examined,
            r.shape.mean_list,
            p.tra_lookup_ns / r.work.nodes,
            p.lookup_ns / r.work.nodes,
            p.tra_lookup_ns / p.tra_sorted_ns,
            p.lookup_ns / p.sorted_ns
        );
    }
    s
}

/// The CSV: a line per set and scheme.
fn csv(rows: &[Row], cpu: &str) -> String {
    let mut s = String::from(
        "set,target,accuracy,records,samples,nodes,depth,lists,mean_list,max_list,nodes_per_lookup,\
         examined_per_lookup,valid_per_lookup,hit_rate,scheme,lookup_ns,tra_lookup_ns,ratio_q1,\
         ratio_median,ratio_q3,sorted_ns,tra_sorted_ns,sorted_ratio_q1,sorted_ratio_median,\
         sorted_ratio_q3,insert_ns,tra_insert_ns,insert_ratio_q1,insert_ratio_median,\
         insert_ratio_q3,first_ns,tra_first_ns,fill_ns,tra_fill_ns,cpu\n",
    );
    for r in rows {
        for p in &r.pairs {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{:.3},{},{:.3},{:.3},{:.4},{:.4},{},{:.1},{:.1},{:.4},{:.4},\
                 {:.4},{:.1},{:.1},{:.4},{:.4},{:.4},{:.1},{:.1},{:.4},{:.4},{:.4},{:.1},{:.1},{:.1},\
                 {:.1},\"{cpu}\"",
                r.kind,
                r.target.map_or(String::new(), |t| t.to_string()),
                r.accuracy,
                r.records,
                r.samples.map_or(String::new(), |n| n.to_string()),
                r.shape.nodes,
                r.shape.depth,
                r.shape.lists,
                r.shape.mean_list,
                r.shape.max_list,
                r.work.nodes,
                r.work.examined,
                r.work.valid,
                r.work.hit_rate,
                p.scheme,
                p.lookup_ns,
                p.tra_lookup_ns,
                p.ratio.0,
                p.ratio.1,
                p.ratio.2,
                p.sorted_ns,
                p.tra_sorted_ns,
                p.sorted_ratio.0,
                p.sorted_ratio.1,
                p.sorted_ratio.2,
                p.insert_ns,
                p.tra_insert_ns,
                p.insert_ratio.0,
                p.insert_ratio.1,
                p.insert_ratio.2,
                p.first_ns,
                p.tra_first_ns,
                p.fill_ns,
                p.tra_fill_ns
            );
        }
    }
    s
}

/// Writes the page and the CSV.
pub fn write(started: &Context, rows: &[Row], run: &Run) {
    let cpu = cpu();
    let commit = command("git", &["rev-parse", "--short", "HEAD"]);
    let dirty = !command("git", &["status", "--porcelain", "--untracked-files=no"]).is_empty();
    let rustc = command("rustc", &["-V"]);
    let ended = Context::now();
    let mut s = String::new();
    let _ = write!(
        s,
        "# Lookup and insert cost against the records held (issue 42, point 1)\n\n\
         Written by `cargo bench --bench records_held` (what it measures and how: \
         [docs/performance.md](../../docs/performance.md#records-held)).\n\n\
         - machine: **{cpu}**, {cores} logical CPUs; {rustc}; commit {commit}{dirty}\n\
         - run: {} to {}; load average (1, 5, 15 min) {} at the start, {} at the end. The \
         busiest other processes at the start: {}; at the end: {}. The nanoseconds carry \
         whatever load those put on the machine; the ABBA ratios are what to read.\n\
         - {} ABBA rounds of {} queries per pair, {} insert rounds of 1 024 records. Every figure \
         is from this CPU; do not compare it with another CPU's.\n\n",
        started.date,
        ended.date,
        started.load,
        ended.load,
        started.busy,
        ended.busy,
        run.rounds,
        super::QUERIES,
        run.insert_rounds,
        cores = std::thread::available_parallelism().map_or(0, |n| n.get()),
        dirty = if dirty {
            " (with uncommitted changes)"
        } else {
            ""
        },
    );
    s.push_str(
        "What this run shows, and where the time goes, read by hand: [analysis.md](analysis.md).\n\n",
    );
    s.push_str("## Goals\n\n");
    s.push_str(&goals(rows));
    s.push_str("\n## Fitted growth (Ward sets)\n\n");
    s.push_str(&growth(rows));
    s.push_str("\n## Where the time goes\n\n");
    s.push_str(&where_time_goes(rows));
    s.push_str("\n## The sets, and what a lookup does in them\n\n");
    s.push_str(&tables(rows));
    s.push_str(&std::fs::read_to_string(notes_path()).unwrap_or_default());
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results/records-held");
    std::fs::create_dir_all(&dir).expect("results/records-held");
    std::fs::write(dir.join("README.md"), s).expect("write the page");
    std::fs::write(dir.join("results.csv"), csv(rows, &cpu)).expect("write the CSV");
    eprintln!("wrote {}", dir.display());
}

/// Notes kept beside the bench and appended to the page (how the sets are made, how to read it).
fn notes_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/records_held/notes.md")
}
