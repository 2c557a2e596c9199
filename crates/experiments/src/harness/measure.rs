//! Measurement: repeat a setting, time a render or an external command, show progress.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::process::{Command, Output};
use std::time::Instant;

/// Runs `f` and returns its value and the wall seconds it took.
pub fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let start = Instant::now();
    let value = f();
    (value, start.elapsed().as_secs_f64())
}

/// Runs `f(i)` for `i` in `0..n`, every repeat of one setting, stopping at the first error.
pub fn repeat<T, E>(n: usize, f: impl FnMut(usize) -> Result<T, E>) -> Result<Vec<T>, E> {
    (0..n).map(f).collect()
}

/// Runs `cmd` (its standard input and output as the caller set them; its standard error
/// captured) and returns its output and wall seconds. `what` names it in the errors: one that
/// cannot start, one that exits unsuccessfully (with its standard error).
pub fn time_command(cmd: &mut Command, what: &str) -> Result<(Output, f64), String> {
    let (out, seconds) = timed(|| cmd.output());
    let out = out.map_err(|e| format!("{what}: cannot start: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{what} failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok((out, seconds))
}

/// A progress bar over a run's steps on standard error, hidden with `--quiet` or when standard
/// error is not a terminal (then, with [`Progress::echo`], each step's label is printed instead).
pub struct Progress {
    bar: ProgressBar,
    started: bool,
    echo: bool,
}

impl Progress {
    /// A bar of `len` steps.
    pub fn new(len: usize, quiet: bool) -> Self {
        let hidden = quiet || !std::io::stderr().is_terminal();
        let bar = if hidden {
            ProgressBar::hidden()
        } else {
            let bar = ProgressBar::with_draw_target(Some(len as u64), ProgressDrawTarget::stderr());
            if let Ok(style) = ProgressStyle::with_template(
                "[{elapsed_precise}] {wide_bar} {pos}/{len} frames (eta {eta}) {msg}",
            ) {
                bar.set_style(style);
            }
            bar
        };
        Self {
            bar,
            started: false,
            echo: false,
        }
    }

    /// Prints each label as a line when the bar is hidden but the run is not quiet.
    pub fn echo(mut self, quiet: bool) -> Self {
        self.echo = !quiet && self.bar.is_hidden();
        self
    }

    /// A new step `label` begins: the previous one is done.
    fn step(&mut self, label: &str) {
        if self.started {
            self.bar.inc(1);
        }
        self.started = true;
        if self.echo {
            eprintln!("{label}");
        } else {
            self.bar.set_message(label.to_owned());
        }
    }

    /// Runs `experiment` with this progress as its step callback, then clears the bar.
    pub fn run<T>(mut self, experiment: impl FnOnce(&mut dyn FnMut(&str)) -> T) -> T {
        let out = experiment(&mut |label| self.step(label));
        self.bar.finish_and_clear();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_timed_and_failures_named() {
        let (out, s) = time_command(Command::new("sh").args(["-c", "echo hi"]), "sh").unwrap();
        assert_eq!(String::from_utf8_lossy(&out.stdout), "hi\n");
        assert!(s > 0.0);
        let e = time_command(
            Command::new("sh").args(["-c", "echo oops >&2; exit 3"]),
            "the tool",
        )
        .unwrap_err();
        assert!(
            e.starts_with("the tool failed (") && e.ends_with("): oops"),
            "{e}"
        );
        let e = time_command(&mut Command::new("/nonexistent/tool"), "tool").unwrap_err();
        assert!(e.starts_with("tool: cannot start: "), "{e}");
    }

    #[test]
    fn repeats_stop_at_the_first_error_and_steps_count() {
        let v: Result<Vec<usize>, String> = repeat(3, |i| Ok(i * 2));
        assert_eq!(v.unwrap(), vec![0, 2, 4]);
        let mut ran = 0;
        let e: Result<Vec<()>, String> = repeat(5, |i| {
            ran += 1;
            if i == 1 {
                Err("no".into())
            } else {
                Ok(())
            }
        });
        assert_eq!((e.unwrap_err().as_str(), ran), ("no", 2));
        let ((), s) = timed(|| std::thread::sleep(std::time::Duration::from_millis(5)));
        assert!(s >= 0.005, "{s}");
        let mut p = Progress::new(3, true);
        for l in ["a", "b", "c"] {
            p.step(l);
        }
        assert_eq!(p.bar.position(), 2, "the last step is still running");
    }
}
