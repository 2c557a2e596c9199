//! Where and how a result was made: the [`Machine`] and the [`Provenance`] header every generated
//! Markdown page starts with and every CSV carries beside it.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The machine a run measured.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Machine {
    /// Cores available to this process (`std::thread::available_parallelism`).
    pub cores: usize,
    /// CPU model from `/proc/cpuinfo` (or `unknown CPU`).
    pub cpu: String,
}

impl Machine {
    /// The machine this process runs on.
    pub fn detect() -> Self {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_owned())
            })
            .unwrap_or_else(|| "unknown CPU".to_owned());
        Self { cores, cpu }
    }

    /// Whether `workers` threads or processes are more than the cores: they measure
    /// time-slicing, not scaling.
    pub fn oversubscribed(&self, workers: usize) -> bool {
        workers > self.cores
    }

    /// `N` threads or processes as the tables print them: `N*` when oversubscribed.
    pub fn count(&self, workers: usize) -> String {
        format!(
            "{workers}{}",
            super::table::star(self.oversubscribed(workers))
        )
    }

    /// One line naming the cores and the oversubscribed thread counts among `threads`.
    pub fn banner(&self, threads: &[usize]) -> String {
        self.banner_with_ranks(threads, &[])
    }

    /// [`Self::banner`] with MPI layouts too, each `(ranks, threads per rank)`: a layout is
    /// oversubscribed when its ranks' threads together are more than the cores.
    pub fn banner_with_ranks(&self, threads: &[usize], ranks: &[(usize, usize)]) -> String {
        let over: BTreeSet<usize> = (threads.iter().copied())
            .filter(|&t| self.oversubscribed(t))
            .collect();
        let mut parts: Vec<String> = Vec::new();
        if !over.is_empty() {
            let list: Vec<String> = over.iter().map(usize::to_string).collect();
            parts.push(format!("{} threads", list.join(", ")));
        }
        let mut layouts = ranks.to_vec();
        layouts.retain(|&(r, t)| self.oversubscribed(r * t));
        layouts.dedup();
        for (r, t) in layouts {
            let s = if t == 1 { "" } else { "s" };
            parts.push(format!("{r} ranks x {t} thread{s}"));
        }
        let what = ["thread count", "thread or rank count"][usize::from(!ranks.is_empty())];
        let tail = if parts.is_empty() {
            format!("no {what} is oversubscribed")
        } else {
            format!(
                "OVERSUBSCRIBED (time-sliced, not scaling): {}",
                parts.join("; ")
            )
        };
        format!(
            "machine: {} cores ({}); {tail}",
            self.cores,
            self.cpu.trim()
        )
    }
}

/// The header of a generated file: the command line, the git commit, rustc's version, the UTC
/// date, the machine and which of the run's thread and rank counts are oversubscribed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Provenance {
    /// The command line that made the file.
    pub command: String,
    /// `git rev-parse --short HEAD`, or `unknown`.
    pub commit: String,
    /// `rustc --version`, or `unknown`.
    pub rustc: String,
    /// The UTC date and time the header was made, `YYYY-MM-DD HH:MM UTC`.
    pub date: String,
    /// The machine.
    pub machine: Machine,
    /// The run's thread counts (one process each).
    pub threads: Vec<usize>,
    /// The run's MPI layouts, `(ranks, threads per rank)`.
    pub ranks: Vec<(usize, usize)>,
}

/// The first line of `program args`' standard output, or `unknown`.
fn first_line(program: &str, args: &[&str]) -> String {
    Command::new(program)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| {
            let text = String::from_utf8_lossy(&o.stdout);
            text.lines().next().map(|l| l.trim().to_owned())
        })
        .filter(|l| !l.is_empty())
        .unwrap_or_else(|| "unknown".to_owned())
}

/// `YYYY-MM-DD HH:MM UTC` for `secs` seconds after the Unix epoch (proleptic Gregorian).
pub fn utc_date(secs: u64) -> String {
    let (days, rest) = ((secs / 86_400) as i64, secs % 86_400);
    // Howard Hinnant's civil_from_days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02} UTC",
        rest / 3600,
        rest % 3600 / 60
    )
}

/// This process's command line, as `wfic ARGS...`.
pub fn command_line() -> String {
    let mut words = vec!["wfic".to_owned()];
    words.extend(std::env::args().skip(1));
    words.join(" ")
}

impl Provenance {
    /// The header for a run of `command` on `machine` at `threads` and `ranks`, the commit,
    /// compiler and date found now.
    pub fn new(
        command: &str,
        machine: &Machine,
        threads: &[usize],
        ranks: &[(usize, usize)],
    ) -> Self {
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        Self {
            command: command.to_owned(),
            commit: first_line("git", &["rev-parse", "--short", "HEAD"]),
            rustc: first_line("rustc", &["--version"]),
            date: utc_date(now),
            machine: machine.clone(),
            threads: threads.to_vec(),
            ranks: ranks.to_vec(),
        }
    }

    /// The header's lines.
    pub fn lines(&self) -> Vec<String> {
        vec![
            format!("command: `{}`", self.command),
            format!("git commit {}; {}; {}", self.commit, self.rustc, self.date),
            self.machine.banner_with_ranks(&self.threads, &self.ranks),
        ]
    }

    /// A Markdown page: `# title`, this header as a list, then `body`.
    pub fn page(&self, title: &str, body: &str) -> String {
        let header: String = self.lines().iter().map(|l| format!("- {l}\n")).collect();
        format!("# {title}\n\n{header}\n{body}")
    }
}

/// Where an experiment writes its files, each with its provenance.
pub struct Output<'a> {
    /// The folder.
    pub dir: PathBuf,
    /// The header every file carries.
    pub provenance: &'a Provenance,
}

impl<'a> Output<'a> {
    /// The folder `dir` (created), its files headed by `provenance`.
    pub fn new(dir: &Path, provenance: &'a Provenance) -> Result<Self, String> {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        Ok(Self {
            dir: dir.to_owned(),
            provenance,
        })
    }

    /// The path of `name` in the folder.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Writes the Markdown page `name`: `# title`, the header, `body`.
    pub fn markdown(&self, name: &str, title: &str, body: &str) -> Result<(), String> {
        write_file(&self.path(name), &self.provenance.page(title, body))
    }

    /// Writes `figure` as `STEM.png` and `STEM.svg`.
    pub fn figure(&self, stem: &str, figure: &crate::plot::Figure) -> Result<(), String> {
        let png = self.path(&format!("{stem}.png"));
        (figure.render()?.save(&png)).map_err(|e| format!("{}: {e}", png.display()))?;
        write_file(&self.path(&format!("{stem}.svg")), &figure.render_svg()?)
    }

    /// Writes the CSV `name` as it is (a CSV reader sees only the table) and its header beside
    /// it, in `NAME.provenance` (one line each).
    pub fn csv(&self, name: &str, text: &str) -> Result<(), String> {
        write_file(&self.path(name), text)?;
        let lines = self.provenance.lines().join("\n");
        write_file(
            &self.path(&format!("{name}.provenance")),
            &format!("provenance of {name}\n{lines}\n"),
        )
    }
}

/// Writes `text` to `path`, naming the path in the error.
fn write_file(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_cores() -> Machine {
        Machine {
            cores: 2,
            cpu: "Test CPU".into(),
        }
    }

    #[test]
    fn banner_names_the_oversubscribed_thread_and_rank_counts() {
        let m = two_cores();
        assert!(!m.oversubscribed(2));
        assert!(m.oversubscribed(4));
        let b = m.banner(&[1, 2, 4, 8, 4]);
        assert!(b.contains("2 cores (Test CPU)"), "{b}");
        assert!(b.contains("OVERSUBSCRIBED"), "{b}");
        assert!(b.ends_with(": 4, 8 threads"), "{b}");
        assert!(m
            .banner(&[1, 2])
            .contains("no thread count is oversubscribed"));
        let r = m.banner_with_ranks(&[2], &[(1, 2), (2, 1), (4, 1), (2, 2)]);
        assert!(
            r.ends_with(": 4 ranks x 1 thread; 2 ranks x 2 threads"),
            "{r}"
        );
        assert!(m
            .banner_with_ranks(&[1], &[(2, 1)])
            .ends_with("no thread or rank count is oversubscribed"));
    }

    #[test]
    fn dates_are_civil_utc() {
        assert_eq!(utc_date(0), "1970-01-01 00:00 UTC");
        assert_eq!(utc_date(951_782_400 + 3_660), "2000-02-29 01:01 UTC");
        assert_eq!(utc_date(1_798_675_200), "2026-12-31 00:00 UTC");
    }

    #[test]
    fn every_file_carries_the_header() {
        let p = Provenance::new("wfic test", &two_cores(), &[1, 4], &[]);
        assert!(!p.commit.is_empty() && !p.rustc.is_empty());
        let md = p.page("T", "body\n");
        assert!(
            md.starts_with("# T\n\n- command: `wfic test`\n- git commit "),
            "{md}"
        );
        assert!(
            md.contains("OVERSUBSCRIBED (time-sliced, not scaling): 4 threads"),
            "{md}"
        );
        assert!(md.ends_with("\n\nbody\n"), "{md}");
        let dir = std::env::temp_dir().join(format!("wfic-prov-{}", std::process::id()));
        let out = Output::new(&dir, &p).unwrap();
        out.csv("x.csv", "a,b\n1,2\n").unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join("x.csv")).unwrap(),
            "a,b\n1,2\n"
        );
        let side = std::fs::read_to_string(dir.join("x.csv.provenance")).unwrap();
        assert!(
            side.contains("command: `wfic test`") && side.contains(" UTC"),
            "{side}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
