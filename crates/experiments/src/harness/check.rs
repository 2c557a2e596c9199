//! Checks: a statement a run must make hold, how it came out, and the figures it was decided on.

use super::table::Table;

/// How a check came out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// It holds.
    Yes,
    /// A timing comparison whose paired-ratio interval contains 1: the runs cannot tell the two
    /// apart.
    Tie,
    /// It does not hold (for a timing comparison: the whole interval is on the wrong side).
    No,
    /// The goal is missed, but the interval reaches what the machine allows
    /// ([`super::control::SpeedupAnalysis::ceiling`]).
    Machine,
}

impl Verdict {
    /// [`Verdict::Yes`] when `holds`, else [`Verdict::No`].
    pub fn of(holds: bool) -> Self {
        if holds {
            Verdict::Yes
        } else {
            Verdict::No
        }
    }

    /// How the Markdown reports say it: `yes`, `tie (within noise)`, `**NO**`, or the machine's.
    pub fn text(self) -> &'static str {
        match self {
            Verdict::Yes => "yes",
            Verdict::Tie => "tie (within noise)",
            Verdict::No => "**NO**",
            Verdict::Machine => "no: the machine's (speed-up table)",
        }
    }

    /// How the terminal says it (no Markdown emphasis).
    pub fn plain(self) -> &'static str {
        self.text().trim_matches('*')
    }
}

/// A statement the reproduction must make hold, evaluated on a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Check {
    /// Scene (empty when the experiment has one).
    pub scene: String,
    /// What is claimed.
    pub claim: String,
    /// How it came out.
    pub verdict: Verdict,
    /// The figures it was decided on.
    pub detail: String,
}

impl Check {
    /// A check of `scene`.
    pub fn new(scene: &str, claim: impl Into<String>, verdict: Verdict, detail: String) -> Self {
        Self {
            scene: scene.to_owned(),
            claim: claim.into(),
            verdict,
            detail,
        }
    }

    /// The checks as a Markdown table (with a scene column when `scenes`).
    pub fn markdown(checks: &[Check], scenes: bool) -> String {
        let mut t = Table::new();
        if scenes {
            t = t.md("scene", |c: &Check| c.scene.clone()).left();
        }
        t.md("claim", |c| c.claim.clone())
            .left()
            .md("holds", |c| c.verdict.text().to_owned())
            .left()
            .md("measured", |c| c.detail.clone())
            .left()
            .markdown(checks)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts_read_as_the_reports_say_them() {
        assert_eq!(Verdict::of(true), Verdict::Yes);
        assert_eq!(Verdict::of(false).text(), "**NO**");
        assert_eq!(Verdict::No.plain(), "NO");
        assert_eq!(
            Verdict::Machine.plain(),
            "no: the machine's (speed-up table)"
        );
        let c = [Check::new("s", "it holds", Verdict::Tie, "1.0".into())];
        assert_eq!(
            Check::markdown(&c, true),
            "| scene | claim | holds | measured |\n|---|---|---|---|\n| s | it holds | tie (within noise) | 1.0 |\n"
        );
        assert!(Check::markdown(&c, false).starts_with("| claim |"));
    }
}
