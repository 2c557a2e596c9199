//! The list of schemes: what the CLI, the experiments and the tests choose from, with each
//! scheme's name, description, table heading, plot colour and constructor. Free of any CLI crate:
//! `wfic render` derives its argument parser from this list.

use super::wf::Minimal;
use super::{
    CacheConfig, CasFailure, IrradianceCache, LocalWrite, Locked, MutexFlavour, NoCache,
    RwLockFlavour, Sequential, WaitFree,
};
use std::fmt;

/// A way of sharing an irradiance cache (paper §3), or none at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Scheme {
    /// TRA: the sequential octree (one thread holds it for the frame).
    Tra,
    /// LCK: the octree behind a `Mutex` (the paper).
    Lck,
    /// LCK with an `RwLock` (what pbrt-v2 did).
    LckRw,
    /// LW: per-thread local caches merged at frame end.
    Lw,
    /// WF: the wait-free octree; the loser of a child race adopts the winner's child.
    Wf,
    /// WF with the paper's policy: the loser of a child race discards its sample.
    WfDiscard,
    /// No cache: the indirect term estimated at every shading point (the reference).
    None,
}

/// An RGB colour, 8 bits per channel.
pub type Rgb8 = [u8; 3];

impl Scheme {
    /// Every scheme, the reference last.
    pub const ALL: [Scheme; 7] = [
        Self::Tra,
        Self::Lck,
        Self::LckRw,
        Self::Lw,
        Self::Wf,
        Self::WfDiscard,
        Self::None,
    ];

    /// Every scheme that caches (all but [`Scheme::None`]), in the order tables list them.
    pub const CACHED: [Scheme; 6] = [
        Self::Tra,
        Self::Lck,
        Self::LckRw,
        Self::Lw,
        Self::Wf,
        Self::WfDiscard,
    ];

    /// The name, as the CLI spells it and [`IrradianceCache::scheme`] returns it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Tra => "tra",
            Self::Lck => "lck",
            Self::LckRw => "lck-rw",
            Self::Lw => "lw",
            Self::Wf => "wf",
            Self::WfDiscard => "wf-discard",
            Self::None => "none",
        }
    }

    /// The scheme named `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// One line on what the scheme does.
    pub const fn description(self) -> &'static str {
        match self {
            Self::Tra => "sequential octree (one thread holds it for the frame)",
            Self::Lck => "octree behind a Mutex, locked per lookup and per insert",
            Self::LckRw => "octree behind an RwLock (shared lookups, exclusive inserts)",
            Self::Lw => "per-thread local caches merged at frame end",
            Self::Wf => "wait-free octree; the loser of a child race adopts the winner's child",
            Self::WfDiscard => {
                "wait-free octree; the loser of a child race discards its sample (the paper)"
            }
            Self::None => "no cache: the indirect term at every shading point (the reference)",
        }
    }

    /// The heading tables and plots use (the paper's names; `WF-D` is the discarding WF).
    pub const fn heading(self) -> &'static str {
        match self {
            Self::Tra => "TRA",
            Self::Lck => "LCK",
            Self::LckRw => "LCK-RW",
            Self::Lw => "LW",
            Self::Wf => "WF",
            Self::WfDiscard => "WF-D",
            Self::None => "NONE",
        }
    }

    /// The scheme's colour in every plot (a colour-blind-safe categorical palette).
    pub const fn colour(self) -> Rgb8 {
        match self {
            Self::Tra => [60, 60, 60],          // dark grey
            Self::Lck => [214, 39, 40],         // red
            Self::LckRw => [255, 127, 14],      // orange
            Self::Lw => [31, 119, 180],         // blue
            Self::Wf => [44, 160, 44],          // green
            Self::WfDiscard => [148, 103, 189], // purple
            Self::None => [140, 86, 75],        // brown
        }
    }

    /// True for the schemes that share one cache between threads during a frame (TRA's handle
    /// holds the whole cache, so extra threads only wait).
    pub const fn is_concurrent(self) -> bool {
        !matches!(self, Self::Tra)
    }

    /// True for the schemes a deterministic frame ([`super::deterministic`]) can run: all but
    /// [`Scheme::WfDiscard`], which drops a record whose insert loses a race for a child, so which
    /// records a frame keeps depends on the schedule.
    pub const fn is_deterministic(self) -> bool {
        !matches!(self, Self::WfDiscard)
    }

    /// Builds this scheme's cache over `config` and runs `job` on it. WF uses the [`Minimal`]
    /// orderings; [`Scheme::None`] builds a [`NoCache`]. The one place a scheme becomes a type.
    pub fn build<J: CacheJob>(self, config: CacheConfig, job: J) -> J::Output {
        match self {
            Self::Tra => job.run(Sequential::new(config)),
            Self::Lck => job.run(Locked::<MutexFlavour>::new(config)),
            Self::LckRw => job.run(Locked::<RwLockFlavour>::new(config)),
            Self::Lw => job.run(LocalWrite::new(config)),
            Self::Wf => job.run(WaitFree::<Minimal>::new(config, CasFailure::Adopt)),
            Self::WfDiscard => job.run(WaitFree::<Minimal>::new(config, CasFailure::Discard)),
            Self::None => job.run(NoCache::new(config)),
        }
    }
}

impl fmt::Display for Scheme {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Work to run on a freshly built cache, whatever its scheme: callers are generic over
/// [`IrradianceCache`], and [`Scheme::build`] picks the type.
pub trait CacheJob {
    /// What the job returns.
    type Output;
    /// Runs the job on `cache`.
    fn run<C: IrradianceCache>(self, cache: C) -> Self::Output;
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use glam::Vec3;

    struct Name;

    impl CacheJob for Name {
        type Output = Scheme;
        fn run<C: IrradianceCache>(self, cache: C) -> Scheme {
            cache.scheme()
        }
    }

    #[test]
    fn every_scheme_builds_the_cache_it_names() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::ONE, 0.25).unwrap();
        for scheme in Scheme::ALL {
            assert_eq!(scheme.build(config, Name), scheme);
            assert_eq!(Scheme::from_name(scheme.name()), Some(scheme));
        }
        assert_eq!(Scheme::from_name("wf-adopt"), None);
    }

    #[test]
    fn names_headings_and_colours_are_distinct() {
        for (i, a) in Scheme::ALL.iter().enumerate() {
            for b in &Scheme::ALL[i + 1..] {
                assert_ne!(a.name(), b.name());
                assert_ne!(a.heading(), b.heading());
                assert_ne!(a.colour(), b.colour(), "{a} and {b} share a colour");
            }
        }
        assert!(Scheme::CACHED.iter().all(|s| *s != Scheme::None));
    }

    #[test]
    fn descriptions_concurrency_and_display() {
        for (i, a) in Scheme::ALL.iter().enumerate() {
            assert!(a.description().len() > 20, "{a}: {:?}", a.description());
            assert_eq!(a.to_string(), a.name());
            for b in &Scheme::ALL[i + 1..] {
                assert_ne!(a.description(), b.description());
            }
        }
        // TRA's handle holds the whole cache: the only scheme whose threads do not share it.
        let concurrent: Vec<Scheme> = Scheme::ALL
            .into_iter()
            .filter(|s| s.is_concurrent())
            .collect();
        assert_eq!(concurrent.len(), Scheme::ALL.len() - 1);
        assert!(!Scheme::Tra.is_concurrent());
    }
}
