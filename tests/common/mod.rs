//! Shared by the integration tests: run a check against every scheme, and make records
//! deterministically from `(worker, seq)` so that any record read back can be checked against
//! what was inserted.
#![allow(dead_code)]

use glam::Vec3;
use wfic::cache::{
    CacheConfig, CasFailure, IrradianceCache, LocalWrite, Locked, MutexFlavour, RwLockFlavour,
    Sequential, WaitFree,
};
use wfic::ic::{Record, RecordId, WorkerId};

/// Something to run against each scheme.
pub trait SchemeCheck {
    /// Runs the check on a fresh, empty `cache`.
    fn check<C: IrradianceCache>(&mut self, cache: C);
}

/// Every scheme the crate offers: TRA, LCK (mutex and rwlock), LW, WF (adopt and discard).
pub const SCHEMES: [&str; 6] = ["tra", "lck", "lck-rw", "lw", "wf", "wf-discard"];

/// Runs `check` on a fresh cache of the scheme named `scheme`.
pub fn with_scheme(scheme: &str, config: CacheConfig, check: &mut impl SchemeCheck) {
    match scheme {
        "tra" => check.check(Sequential::new(config)),
        "lck" => check.check(Locked::<MutexFlavour>::new(config)),
        "lck-rw" => check.check(Locked::<RwLockFlavour>::new(config)),
        "lw" => check.check(LocalWrite::new(config)),
        "wf" => check.check(WaitFree::<wfic::cache::wf::Minimal>::new(
            config,
            CasFailure::Adopt,
        )),
        "wf-discard" => check.check(WaitFree::<wfic::cache::wf::Minimal>::new(
            config,
            CasFailure::Discard,
        )),
        other => panic!("unknown scheme {other}"),
    }
}

/// Runs `check` on a fresh cache of every scheme.
pub fn for_each_scheme(config: CacheConfig, check: &mut impl SchemeCheck) {
    for scheme in SCHEMES {
        with_scheme(scheme, config, check);
    }
}

/// The crate's deterministic generator, for test data.
pub use wfic::rng::Rng;

/// The six axis-aligned unit normals.
pub const AXES: [Vec3; 6] = [
    Vec3::X,
    Vec3::NEG_X,
    Vec3::Y,
    Vec3::NEG_Y,
    Vec3::Z,
    Vec3::NEG_Z,
];

/// The stress tests' world: a 10-unit box.
pub fn world(accuracy: f32) -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), accuracy).unwrap()
}

/// The record worker `worker` inserts as its `seq`-th: a pure function of both, so a reader can
/// tell whether a record it met is one that was really inserted.
pub fn record_for(worker: u32, seq: u64) -> Record {
    let mut rng = Rng::new((u64::from(worker) << 40) ^ seq ^ 0x5eed);
    let position = Vec3::new(
        rng.range(0.0, 10.0),
        rng.range(0.0, 10.0),
        rng.range(0.0, 10.0),
    );
    let normal = AXES[rng.below(6) as usize];
    let irradiance = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0;
    let radius = rng.range(0.2, 0.6);
    let g = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.1;
    Record::new(position, normal, irradiance, radius).with_gradients([g, -g, g * 0.5], [-g, g, g])
}

/// True when `r` is intact and is exactly the record its id says was inserted.
pub fn is_genuine(r: &Record) -> bool {
    let id: RecordId = r.id();
    let expected = record_for(id.worker().index(), id.seq());
    r.is_intact()
        && r.position == expected.position
        && r.normal == expected.normal
        && r.irradiance == expected.irradiance
        && r.radius == expected.radius
        && r.grad_t == expected.grad_t
        && r.grad_r == expected.grad_r
}

/// A worker id.
pub fn w(n: u32) -> WorkerId {
    WorkerId::new(n)
}
