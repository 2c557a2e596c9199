//! Every numeric option of every subcommand, at and beyond the edges of its range and at values
//! no range holds (huge, zero, negative, NaN, infinite, not a number): the `wfic` process exits
//! 0 or 2, never with a panic or an abort, within a bounded time; a value outside the range is
//! refused naming the option and the range. `render` runs for real on a 4 x 4 image; the other
//! subcommands stop after their checks (`--dry-run`), so an in-range value that asks for hours
//! of work (a billion demo points) is still checked in full.

#![cfg(not(checker))]

use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use wfic_experiments::bounds::{self, Bound};

/// A run that takes longer than this has not stayed tiny.
const TIME_LIMIT: Duration = Duration::from_secs(120);

fn temp_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wfic-command-line-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The arguments a case starts from: a tiny run of the subcommand, as `(option, value)` pairs
/// the case's own option replaces.
fn base(path: &[&str], dir: &Path) -> (Vec<String>, Vec<(String, String)>) {
    let d = dir.to_string_lossy().into_owned();
    let pairs: &[(&str, &str)] = match path {
        ["render"] => &[
            ("width", "4"),
            ("height", "4"),
            ("rays-per-record", "16"),
            ("light-samples", "1"),
            ("accuracy", "0.5"),
        ],
        ["demo"] => &[("points", "100"), ("frames", "1"), ("work", "10")],
        ["compare", "radiance"] => &[("scene", "cornell")],
        _ => &[],
    };
    let mut head: Vec<String> = path.iter().map(|s| s.to_string()).collect();
    if path != ["render"] {
        head.insert(0, "--dry-run".into());
    }
    let mut pairs: Vec<(String, String)> = pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    match path {
        ["render"] => pairs.push(("out".into(), format!("{d}/r.png"))),
        ["demo"] => {}
        _ => pairs.push(("out-dir".into(), format!("{d}/out"))),
    }
    (head, pairs)
}

/// Runs `wfic` with `args`: its exit code (`None`: killed by a signal) and its standard error.
fn run(args: &[String]) -> (Option<i32>, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_wfic"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("wfic starts");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > TIME_LIMIT {
            child.kill().ok();
            panic!("wfic {args:?} ran longer than {TIME_LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    (status.code(), err)
}

/// Whether `value` parses into the option's type and lies inside its range.
fn inside(bound: Bound, value: &str) -> bool {
    match bound {
        Bound::U32(l) => value.parse().is_ok_and(|v| l.contains(v)),
        Bound::U64(l) => value.parse().is_ok_and(|v| l.contains(v)),
        Bound::Usize(l) => value.parse().is_ok_and(|v| l.contains(v)),
        Bound::F32(l) => value.parse().is_ok_and(|v| l.contains(v)),
        Bound::Point(l) => {
            let parts: Vec<&str> = value.split(',').collect();
            parts.len() == 3
                && parts
                    .iter()
                    .all(|p| p.parse().is_ok_and(|v: f32| l.contains(v)))
        }
    }
}

/// The values a bound is tried at: its edges, one step beyond each, and the values no range
/// holds.
fn edges(bound: Bound) -> Vec<String> {
    fn ints(min: u128, max: u128) -> Vec<String> {
        let mut v = vec![min.to_string(), max.to_string(), (max + 1).to_string()];
        if min > 0 {
            v.push((min - 1).to_string());
        }
        v
    }
    fn floats(min: f32, max: f32) -> Vec<String> {
        let up = |x: f32| {
            f32::from_bits(if x >= 0.0 {
                x.to_bits() + 1
            } else {
                x.to_bits() - 1
            })
        };
        let down = |x: f32| -up(-x);
        [min, up(min), down(min), max, up(max)]
            .iter()
            .map(|x| format!("{x:?}"))
            .collect()
    }
    let mut values = match bound {
        Bound::U32(l) => ints(l.min.into(), l.max.into()),
        Bound::U64(l) => ints(l.min.into(), l.max.into()),
        Bound::Usize(l) => ints(l.min as u128, l.max as u128),
        Bound::F32(l) | Bound::Point(l) => floats(l.min, l.max),
    };
    values.extend(
        [
            "0",
            "-1",
            "1e40",
            "-1e40",
            "1e300",
            "NaN",
            "inf",
            "-inf",
            "abc",
            "3.5",
            "",
            "18446744073709551616",
        ]
        .map(String::from),
    );
    if let Bound::Point(_) = bound {
        // A point: the same value in every coordinate, one bad coordinate among good ones, and
        // the wrong number of coordinates.
        let mut points: Vec<String> = values.iter().map(|v| format!("{v},{v},{v}")).collect();
        points.extend(values.iter().map(|v| format!("1,{v},2")));
        points.extend(["1,2".into(), "1,2,3,4".into()]);
        values = points;
    }
    values
}

/// The options of `render` that only `--distributed` takes.
const DISTRIBUTED_ONLY: [&str; 4] = ["batch_records", "batch_ms", "frames", "fail_rank"];

/// Runs one case and checks it: exit 0 or 2 in time; outside the range, exit 2 naming the
/// option and the range. Returns the exit code.
fn check(path: &[&str], id: &str, bound: Bound, value: &str, dir: &Path) -> Option<i32> {
    let option = id.replace('_', "-");
    let (mut args, mut pairs) = base(path, dir);
    pairs.retain(|(k, _)| *k != option);
    if path == ["render"] && DISTRIBUTED_ONLY.contains(&id) {
        args.push("--distributed".into());
    }
    for (k, v) in pairs {
        args.extend([format!("--{k}"), v]);
    }
    args.push(format!("--{option}={value}"));
    let (code, err) = run(&args);
    assert!(
        matches!(code, Some(0 | 2)),
        "wfic {args:?} exited {code:?} (a panic or an abort): {err}"
    );
    if !inside(bound, value) {
        assert_eq!(code, Some(2), "wfic {args:?} took {value:?}");
        assert!(
            err.contains(&format!("--{option}")) && err.contains(&bound.range()),
            "wfic {args:?}: the refusal names neither the option nor the range {}: {err}",
            bound.range()
        );
    }
    code
}

#[test]
fn every_numeric_option_at_and_beyond_its_edges_exits_cleanly() {
    let dir = temp_dir();
    let mut cases = 0;
    for (path, id, bound) in bounds::table() {
        let mut ran = 0;
        for value in edges(bound) {
            let code = check(path, id, bound, &value, &dir);
            ran += usize::from(code == Some(0));
            cases += 1;
        }
        // Inside the range the run goes ahead (only `--distributed` needs the `mpi` feature,
        // which `cargo test` builds without): the base arguments are not what refuses.
        let needs_mpi = path == ["render"] && DISTRIBUTED_ONLY.contains(&id);
        assert!(
            ran > 0 || (needs_mpi && !cfg!(feature = "mpi")),
            "wfic {} --{id}: no value inside the range ran",
            path.join(" ")
        );
    }
    // Every entry of the table was tried at a dozen values or more.
    assert!(cases >= 12 * bounds::table().len(), "{cases} cases");
    std::fs::remove_dir_all(&dir).ok();
}

/// Every option that takes a number is in the table: its help states the range.
#[test]
fn every_numeric_option_states_its_range_in_its_help() {
    use clap::builder::ValueParser;
    fn walk(c: &clap::Command, path: &str, found: &mut Vec<String>) {
        for a in c.get_arguments() {
            let t = a.get_value_parser().type_id();
            let numeric = [
                ValueParser::new(|s: &str| s.parse::<u32>()).type_id(),
                ValueParser::new(|s: &str| s.parse::<u64>()).type_id(),
                ValueParser::new(|s: &str| s.parse::<usize>()).type_id(),
                ValueParser::new(|s: &str| s.parse::<f32>()).type_id(),
                ValueParser::new(|s: &str| s.parse::<f32>().map(glam::Vec3::splat)).type_id(),
            ]
            .contains(&t);
            let help = a.get_help().map(|h| h.to_string()).unwrap_or_default();
            if numeric
                && !(help.contains("(in [")
                    || help.contains("(in (")
                    || help.contains("(each coordinate in"))
            {
                found.push(format!("{path} --{}", a.get_id()));
            }
        }
        for s in c.get_subcommands() {
            walk(s, &format!("{path} {}", s.get_name()), found);
        }
    }
    let mut unbounded = Vec::new();
    walk(&wfic_experiments::cli::command(), "wfic", &mut unbounded);
    assert!(
        unbounded.is_empty(),
        "options with no stated range: {unbounded:?}"
    );
}

/// The docs' table of ranges is the one the command line parses with.
#[test]
fn the_docs_list_every_range_as_the_command_line_parses_it() {
    let page = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/command-line.md");
    let text = std::fs::read_to_string(&page).unwrap();
    let table = bounds::markdown();
    if std::env::var_os("WFIC_BLESS").is_some() && !text.contains(&table) {
        let (start, end) = ("<!-- ranges: begin -->\n", "<!-- ranges: end -->");
        let a = text.find(start).expect("begin marker") + start.len();
        let b = text.find(end).expect("end marker");
        std::fs::write(&page, format!("{}{table}{}", &text[..a], &text[b..])).unwrap();
        return;
    }
    assert!(
        text.contains(&table),
        "docs/command-line.md's table of ranges is stale: rerun this test with WFIC_BLESS=1"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Random values, numbers of every size and sign and arbitrary text, on a random option.
    #[test]
    fn random_values_on_random_options_exit_cleanly(
        entry in 0..bounds::table().len(),
        value in prop_oneof![
            any::<i64>().prop_map(|v| v.to_string()),
            any::<u64>().prop_map(|v| v.to_string()),
            any::<f64>().prop_map(|v| format!("{v:e}")),
            any::<f32>().prop_map(|v| v.to_string()),
            "[ -~]{0,12}",
        ],
    ) {
        let (path, id, bound) = bounds::table()[entry];
        let value = match bound {
            Bound::Point(_) => format!("{value},0,0"),
            _ => value,
        };
        let dir = temp_dir();
        let _ = check(path, id, bound, &value, &dir);
    }
}

/// The scene reader's regression corpus (`crates/render/tests/obj-corpus`, the inputs that broke
/// or stretched it, fuzzing's included: docs/verification.md): each file's first line says what
/// `wfic render --obj` must do with it, `# expect: CODE | NEEDLE | ...`, and standard error must
/// hold every needle (an error's file and line, its reason; a warning's).
#[test]
fn the_scene_corpus_renders_or_is_refused_as_each_file_says() {
    let dir = temp_dir();
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../render/tests/obj-corpus");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&corpus)
        .expect("the corpus")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "obj"))
        .collect();
    files.sort();
    assert!(files.len() >= 8, "the corpus: {files:?}");
    for file in files {
        let text = std::fs::read(&file).unwrap();
        let first = String::from_utf8_lossy(text.split(|&b| b == b'\n').next().unwrap());
        let expect = first.strip_prefix("# expect: ").expect("an expectation");
        let mut parts = expect.split(" | ");
        let code: i32 = parts.next().unwrap().trim().parse().unwrap();
        let mut args: Vec<String> = ["render", "--obj"].map(String::from).to_vec();
        args.push(file.to_string_lossy().into_owned());
        for (k, v) in [
            ("width", "4"),
            ("height", "4"),
            ("rays-per-record", "16"),
            ("light-samples", "1"),
            ("accuracy", "0.5"),
        ] {
            args.push(format!("--{k}={v}"));
        }
        args.push(format!("--out={}/corpus.png", dir.display()));
        let (got, err) = run(&args);
        let name = file.file_name().unwrap().to_string_lossy();
        assert_eq!(got, Some(code), "{name}: {err}");
        for needle in parts {
            assert!(err.contains(needle), "{name}: `{needle}` not in: {err}");
        }
    }
}
