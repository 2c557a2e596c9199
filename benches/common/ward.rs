//! Record sets that follow Ward's rule, for `records_held`: a renderer adds a record only where
//! no stored record is valid, so the records' density follows `1 / (a R)^2` and their number grows
//! about as `1 / a^2` as the accuracy `a` shrinks.
//!
//! [`ward_set`] samples surface points of the workload's room uniformly by area and, at each,
//! looks the point up in a sequential octree built at accuracy `a`; on a miss it stores the
//! record the workload's [`Scene::record`] computes there (radius from the distance to the face's
//! edges, clamped to the workload's fixed `[MIN_RADIUS, MAX_RADIUS]`); each batch of samples is
//! visited in Morton order (a renderer's scan is coherent too). It stops once a batch of
//! samples inserts fewer than [`STOP_RATE`] of them: the cache then answers at least 99% of a
//! renderer's lookups, as a converged cache does.
//!
//! The radius clamps stay fixed as `a` shrinks. Ward's rule places records by their influence
//! radius `a R`; with `R`'s clamps fixed, `a R` shrinks by the same factor everywhere, so every
//! region's density grows by the same `1 / a^2` and the set at any `N` is the same scene sampled
//! at a finer accuracy. Clamps scaled with `a` would change the influence radius as `a^2` and
//! make the set's shape, not only its density, depend on `N`. (Radiance's `-ar`, which caps the
//! density at a resolution of the scene, is a renderer's way to stop the growth; it is not
//! modelled.)

use super::{Scene, SurfacePoint};
use glam::Vec3;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use wfic::cache::{CacheConfig, Octree};
use wfic::ic::{Accumulator, Record};
use wfic::rng::Rng;

/// A batch of samples that inserts fewer than this share of them ends the fill.
pub const STOP_RATE: f64 = 0.01;

/// A record set of Ward's rule at one accuracy.
pub struct WardSet {
    /// The accuracy the set was filled at (the caches' accuracy).
    pub accuracy: f32,
    /// The records, in the order the fill stored them.
    pub records: Vec<Record>,
    /// The surface point of each record.
    pub sites: Vec<SurfacePoint>,
    /// Surface points sampled to fill it.
    pub samples: u64,
}

/// The room's cube at accuracy `a`.
pub fn config(a: f32) -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(5.0), a).expect("config")
}

/// The set Ward's rule gives at accuracy `a` (module docs), from the random stream `seed`.
pub fn ward_set(a: f32, seed: u64) -> WardSet {
    let scene = Scene::room();
    let mut rng = Rng::new(seed);
    let mut tree = Octree::new(config(a));
    let (mut records, mut sites, mut samples) = (Vec::new(), Vec::new(), 0u64);
    loop {
        // Batches of an eighth of what is stored (at least 4 096 samples).
        let batch = (records.len() / 8).max(4096);
        let mut inserted = 0usize;
        // A batch is visited along a Morton curve, as a renderer's scan visits its points near
        // one another: uniformly random points would miss the caches at every node past 10^5
        // records and make 10^7 take far longer than minutes.
        let mut points: Vec<(u32, SurfacePoint)> = (0..batch)
            .map(|_| {
                let sp = scene.sample(&mut rng);
                (morton(scene.position(sp).0), sp)
            })
            .collect();
        points.sort_unstable_by_key(|&(key, _)| key);
        for (_, sp) in points {
            let (p, n) = scene.position(sp);
            let mut acc = Accumulator::new(p, n, a, None);
            tree.visit(p, &mut |r| {
                acc.add(r);
            });
            if acc.finish().is_none() {
                let r = scene.record(sp, &mut rng);
                tree.insert(r).expect("record refused");
                records.push(r);
                sites.push(sp);
                inserted += 1;
            }
        }
        samples += batch as u64;
        if (inserted as f64) < STOP_RATE * batch as f64 {
            break;
        }
    }
    WardSet {
        accuracy: a,
        records,
        sites,
        samples,
    }
}

/// The Morton code of `p` in the room's cube, 10 bits an axis.
pub fn morton(p: Vec3) -> u32 {
    let spread = |v: f32| {
        let mut x = ((v / 5.0).clamp(0.0, 1.0) * 1023.0) as u32;
        x = (x | x << 16) & 0x0300_00ff;
        x = (x | x << 8) & 0x0300_f00f;
        x = (x | x << 4) & 0x030c_30c3;
        (x | x << 2) & 0x0924_9249
    };
    spread(p.x) | spread(p.y) << 1 | spread(p.z) << 2
}

/// `count` records of the set's distribution that are not in it: each at a stored record's
/// surface point (chosen uniformly among the records, so the new records follow the set's density)
/// moved uniformly within that record's influence radius `a R` on its face, with the record
/// [`Scene::record`] computes there. Fresh records for the inserts.
pub fn fresh_like(set: &WardSet, count: usize, seed: u64) -> Vec<Record> {
    let scene = Scene::room();
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|_| {
            let i = rng.below(set.records.len() as u64) as usize;
            let (site, f) = (set.sites[i], &scene.faces[set.sites[i].face]);
            let reach = set.accuracy * set.records[i].radius * rng.next_f32().sqrt();
            let angle = rng.range(0.0, std::f32::consts::TAU);
            let sp = SurfacePoint {
                s: (site.s + reach * angle.cos()).clamp(0.0, f.len_u),
                t: (site.t + reach * angle.sin()).clamp(0.0, f.len_v),
                ..site
            };
            scene.record(sp, &mut rng)
        })
        .collect()
}

/// `count` lookup points uniform by area on the room's visible surfaces, with their normals,
/// from the stream `seed`: the same points whatever the accuracy or the number of records.
pub fn uniform_queries(count: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let scene = Scene::room();
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|_| {
            let (p, n) = scene.position(scene.sample(&mut rng));
            // Ray hits are not exactly on the surface.
            (p + n * rng.range(-1e-4, 1e-4), n)
        })
        .collect()
}

/// The set of about `target` records: the accuracy from `hint` (an accuracy and the count it
/// gave), scaled by `sqrt(count / target)`, then corrected until the count is within 15% of the
/// target (at most four fills). Returns the set and the accuracies tried.
pub fn search(target: usize, hint: (f32, usize), seed: u64) -> (WardSet, Vec<f32>) {
    let (mut a, mut n) = hint;
    let mut tried = Vec::new();
    loop {
        a *= (n as f32 / target as f32).sqrt();
        tried.push(a);
        let set = ward_set(a, seed);
        n = set.records.len();
        let off = n as f64 / target as f64;
        if (0.85..=1.15).contains(&off) || tried.len() == 4 {
            return (set, tried);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// On disk, under target/ (not committed): a set of 10^7 records takes minutes to fill
// ---------------------------------------------------------------------------------------------

const MAGIC: &[u8; 8] = b"WFICWARD";

/// Where the set for `target` records is kept: `target/records-held/ward-TARGET-SEED.bin`.
pub fn cache_path(target: usize, seed: u64) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("target/records-held")
        .join(format!("ward2-{target}-{seed:x}.bin"))
}

fn floats(out: &mut Vec<u8>, vs: impl IntoIterator<Item = f32>) {
    for v in vs {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// Writes `set` (with the accuracies tried) to `path`.
pub fn save(path: &Path, set: &WardSet, tried: &[f32]) -> std::io::Result<()> {
    let mut out = Vec::with_capacity(64 + set.records.len() * 124);
    out.extend_from_slice(MAGIC);
    floats(&mut out, [set.accuracy]);
    out.extend_from_slice(&set.samples.to_le_bytes());
    out.extend_from_slice(&(tried.len() as u64).to_le_bytes());
    floats(&mut out, tried.iter().copied());
    out.extend_from_slice(&(set.records.len() as u64).to_le_bytes());
    for (r, sp) in set.records.iter().zip(&set.sites) {
        out.extend_from_slice(&(sp.face as u32).to_le_bytes());
        floats(&mut out, [sp.s, sp.t]);
        out.extend_from_slice(&record_bytes(r));
    }
    std::fs::create_dir_all(path.parent().expect("a folder"))?;
    std::fs::File::create(path)?.write_all(&out)
}

/// A set [`save`] wrote, with the accuracies tried; `None` if absent or not such a file.
pub fn load(path: &Path) -> Option<(WardSet, Vec<f32>)> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .read_to_end(&mut bytes)
        .ok()?;
    let mut at = Reader {
        bytes: &bytes,
        at: 0,
    };
    if at.take(8)? != MAGIC {
        return None;
    }
    let accuracy = at.f32()?;
    let samples = at.u64()?;
    let tried = (0..at.u64()?)
        .map(|_| at.f32())
        .collect::<Option<Vec<_>>>()?;
    let n = at.u64()? as usize;
    let (mut records, mut sites) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for _ in 0..n {
        let face = u32::from_le_bytes(at.take(4)?.try_into().ok()?) as usize;
        let (s, t) = (at.f32()?, at.f32()?);
        sites.push(SurfacePoint { face, s, t });
        records.push(at.record()?);
    }
    Some((
        WardSet {
            accuracy,
            records,
            sites,
            samples,
        },
        tried,
    ))
}

/// A record's 28 fields as little-endian `f32`: position, normal, irradiance, radius, `grad_t`,
/// `grad_r` (the layout `crates/render/examples/dump_records.rs` writes too).
fn record_bytes(r: &Record) -> Vec<u8> {
    let mut out = Vec::with_capacity(112);
    floats(
        &mut out,
        r.position
            .to_array()
            .into_iter()
            .chain(r.normal.to_array())
            .chain(r.irradiance.to_array())
            .chain([r.radius])
            .chain(r.grad_t.iter().chain(&r.grad_r).flat_map(|v| v.to_array())),
    );
    out
}

/// Reads little-endian values off a byte slice.
pub struct Reader<'b> {
    pub bytes: &'b [u8],
    pub at: usize,
}

impl<'b> Reader<'b> {
    pub fn take(&mut self, n: usize) -> Option<&'b [u8]> {
        let s = self.bytes.get(self.at..self.at + n)?;
        self.at += n;
        Some(s)
    }

    pub fn f32(&mut self) -> Option<f32> {
        Some(f32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }

    pub fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }

    pub fn vec3(&mut self) -> Option<Vec3> {
        Some(Vec3::new(self.f32()?, self.f32()?, self.f32()?))
    }

    /// A record in [`record_bytes`]' layout.
    pub fn record(&mut self) -> Option<Record> {
        let (p, n, e, radius) = (self.vec3()?, self.vec3()?, self.vec3()?, self.f32()?);
        let mut g = [Vec3::ZERO; 6];
        for v in &mut g {
            *v = self.vec3()?;
        }
        Some(Record::new(p, n, e, radius).with_gradients([g[0], g[1], g[2]], [g[3], g[4], g[5]]))
    }
}

/// Records computed on a real scene by `crates/render/examples/dump_records.rs`: the cache's
/// configuration, the records, and the camera's lookup points.
pub struct RealSet {
    pub config: CacheConfig,
    pub records: Vec<Record>,
    pub queries: Vec<(Vec3, Vec3)>,
}

/// The real set in `path`, or `None` if absent or not such a file.
pub fn load_real(path: &Path) -> Option<RealSet> {
    let bytes = std::fs::read(path).ok()?;
    let mut at = Reader {
        bytes: &bytes,
        at: 0,
    };
    if at.take(8)? != b"WFICRECS" || at.take(4)? != 1u32.to_le_bytes() {
        return None;
    }
    let a = at.f32()?;
    let (lo, hi) = (at.vec3()?, at.vec3()?);
    let config = CacheConfig::new(lo, hi, a).ok()?;
    let (n, q) = (at.u64()? as usize, at.u64()? as usize);
    let records = (0..n).map(|_| at.record()).collect::<Option<Vec<_>>>()?;
    let queries = (0..q)
        .map(|_| Some((at.vec3()?, at.vec3()?)))
        .collect::<Option<Vec<_>>>()?;
    Some(RealSet {
        config,
        records,
        queries,
    })
}
