//! The irradiance-cache record (paper §2.1; Ward et al. 1988; Ward & Heckbert 1992).

use glam::Vec3;
use std::fmt;

/// The rendering thread that computed a record or asks a question of a cache.
///
/// Invariant: fits in 16 bits (it is packed into a [`RecordId`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct WorkerId(u32);

impl WorkerId {
    /// The largest worker number a [`RecordId`] can carry.
    pub const MAX: u32 = (1 << 16) - 1;

    /// Worker number `n`.
    ///
    /// # Panics
    /// If `n` exceeds [`WorkerId::MAX`]: a record id has 16 bits for it, and a reduced number
    /// would make two workers' records share ids.
    pub const fn new(n: u32) -> Self {
        if n > Self::MAX {
            panic!("worker number exceeds WorkerId::MAX (65535): a record id holds 16 bits of it");
        }
        Self(n)
    }

    /// The worker number.
    pub const fn index(self) -> u32 {
        self.0
    }
}

impl fmt::Display for WorkerId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "worker {}", self.0)
    }
}

/// A record's identity: the worker that inserted it (16 bits), the frame its handle belonged to
/// (16 bits, wrapping) and that handle's running count of inserts (32 bits). Assigned by the cache
/// handle on insert; unique per cache as long as each worker number is used by one handle at a time
/// within a frame (and a cache sees fewer than 2^16 frames).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct RecordId(u64);

impl RecordId {
    /// The `seq`-th record of `worker` in frame `frame` (frame reduced modulo 2^16, seq modulo 2^32).
    pub const fn new(worker: WorkerId, frame: u64, seq: u64) -> Self {
        Self(((worker.0 as u64) << 48) | ((frame & 0xffff) << 32) | (seq & 0xffff_ffff))
    }

    /// The worker that inserted the record.
    pub const fn worker(self) -> WorkerId {
        WorkerId((self.0 >> 48) as u32)
    }

    /// The frame (modulo 2^16) in which it was inserted.
    pub const fn frame(self) -> u64 {
        (self.0 >> 32) & 0xffff
    }

    /// The insert count of its handle when it was inserted.
    pub const fn seq(self) -> u64 {
        self.0 & 0xffff_ffff
    }

    /// The packed value.
    pub const fn get(self) -> u64 {
        self.0
    }
}

impl fmt::Display for RecordId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "r{}.{}.{}", self.worker().0, self.frame(), self.seq())
    }
}

/// One irradiance sample: where it was taken, what it saw, and how far it may be reused.
///
/// The gradients are per colour channel: `grad_t[c]` is the translational gradient of channel `c`
/// (change of irradiance per unit of displacement in the tangent plane) and `grad_r[c]` the
/// rotational one (change per unit of rotation of the normal), as in Ward & Heckbert 1992.
///
/// `id` and `check` are written by the cache on insert: `check` is a hash of every other field, so
/// a reader that sees a half-written ("torn") record can tell ([`Record::is_intact`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    /// Where the hemisphere was sampled.
    pub position: Vec3,
    /// Unit surface normal at `position`.
    pub normal: Vec3,
    /// Irradiance (RGB), non-negative.
    pub irradiance: Vec3,
    /// Harmonic mean distance to the surfaces seen from `position`, already clamped
    /// ([`crate::ic::clamp_radius`]): Ward's `R_i`. Positive.
    pub radius: f32,
    /// Translational gradient per channel.
    pub grad_t: [Vec3; 3],
    /// Rotational gradient per channel.
    pub grad_r: [Vec3; 3],
    id: RecordId,
    check: u64,
}

/// Why a record was refused. The cache is left unchanged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InsertError {
    /// A field holds a NaN or an infinity.
    NonFinite {
        /// The offending field.
        field: &'static str,
    },
    /// The radius is zero or negative.
    NonPositiveRadius(f32),
    /// The normal's length differs from 1 by more than [`Record::NORMAL_TOLERANCE`].
    NormalNotUnit {
        /// Its length.
        length: f32,
    },
    /// An irradiance channel is negative.
    NegativeIrradiance(Vec3),
    /// The position lies outside the cache's root bounds.
    OutOfBounds {
        /// The record's position.
        position: Vec3,
        /// Centre of the root cube.
        center: Vec3,
        /// Half the root cube's edge.
        half_size: f32,
    },
    /// A record list cannot take another record. Only reachable under the `loom` feature, where
    /// lists are shrunk to a few slots so the model checker reaches segment boundaries; the
    /// variant does not exist in other builds.
    #[cfg(feature = "loom")]
    ListFull,
}

impl fmt::Display for InsertError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite { field } => write!(f, "record field `{field}` is not finite"),
            Self::NonPositiveRadius(r) => write!(f, "record radius {r} is not positive"),
            Self::NormalNotUnit { length } => {
                write!(f, "record normal has length {length}, expected 1")
            }
            Self::NegativeIrradiance(e) => write!(f, "record irradiance {e} has a negative channel"),
            Self::OutOfBounds {
                position,
                center,
                half_size,
            } => write!(
                f,
                "record position {position} lies outside the cache bounds (centre {center}, half-size {half_size})"
            ),
            #[cfg(feature = "loom")]
            Self::ListFull => write!(f, "record list is full (model-checking capacity)"),
        }
    }
}

impl std::error::Error for InsertError {}

/// One step of [`Record::digest`]: xor `word` into the state, multiply by an odd constant
/// (a bijection modulo 2^64), then xor-shift right by 29 (a bijection too: the top 29 bits are
/// kept, and from them each lower group in turn).
fn mix(h: u64, word: u64) -> u64 {
    const MULTIPLIER: u64 = 0x9e37_79b9_7f4a_7c15;
    let h = (h ^ word).wrapping_mul(MULTIPLIER);
    h ^ (h >> 29)
}

impl Record {
    /// How far a normal's length may stray from 1.
    pub const NORMAL_TOLERANCE: f32 = 1e-3;

    /// A record without gradients.
    pub fn new(position: Vec3, normal: Vec3, irradiance: Vec3, radius: f32) -> Self {
        Self {
            position,
            normal,
            irradiance,
            radius,
            grad_t: [Vec3::ZERO; 3],
            grad_r: [Vec3::ZERO; 3],
            id: RecordId::default(),
            check: 0,
        }
    }

    /// The same record with translational and rotational gradients.
    pub fn with_gradients(mut self, grad_t: [Vec3; 3], grad_r: [Vec3; 3]) -> Self {
        self.grad_t = grad_t;
        self.grad_r = grad_r;
        self
    }

    /// The identity the cache gave the record (default until inserted).
    pub fn id(&self) -> RecordId {
        self.id
    }

    /// Checks the record's fields; the caches call it before changing anything.
    pub fn validate(&self) -> Result<(), InsertError> {
        let vectors = [
            ("position", self.position),
            ("normal", self.normal),
            ("irradiance", self.irradiance),
            ("grad_t[0]", self.grad_t[0]),
            ("grad_t[1]", self.grad_t[1]),
            ("grad_t[2]", self.grad_t[2]),
            ("grad_r[0]", self.grad_r[0]),
            ("grad_r[1]", self.grad_r[1]),
            ("grad_r[2]", self.grad_r[2]),
        ];
        for (field, v) in vectors {
            if !v.is_finite() {
                return Err(InsertError::NonFinite { field });
            }
        }
        if !self.radius.is_finite() {
            return Err(InsertError::NonFinite { field: "radius" });
        }
        if self.radius <= 0.0 {
            return Err(InsertError::NonPositiveRadius(self.radius));
        }
        let length = self.normal.length();
        if (length - 1.0).abs() > Self::NORMAL_TOLERANCE {
            return Err(InsertError::NormalNotUnit { length });
        }
        if self.irradiance.min_element() < 0.0 {
            return Err(InsertError::NegativeIrradiance(self.irradiance));
        }
        Ok(())
    }

    /// Gives the record its identity and seals it with a hash of its fields (the caches do this
    /// on insert, overwriting any earlier id).
    pub(crate) fn seal(&mut self, id: RecordId) {
        self.id = id;
        self.check = self.digest();
    }

    /// The record with identity `id`, sealed: for code that stores records outside a cache (the
    /// bare-list models, oracles).
    pub fn sealed(mut self, id: RecordId) -> Self {
        self.seal(id);
        self
    }

    /// The key deterministic lookups sum records in: the id, then the check field, so that even
    /// two records whose ids coincide (a frame number that wrapped modulo 2^16) have one order.
    pub(crate) fn canonical_key(&self) -> (RecordId, u64) {
        (self.id, self.check)
    }

    /// True when the check field matches the other fields: the record was read whole, as sealed.
    pub fn is_intact(&self) -> bool {
        self.check == self.digest()
    }

    /// A word-at-a-time hash of the bit patterns of every field but `check`: each 32- or 64-bit
    /// word is xored in, then the state is multiplied by an odd constant and xor-shifted ([`mix`]).
    /// Every step is a bijection of the state, so records that differ in one word reach the last
    /// step with different states; the final `| 1` merges only states that differ in bit 0, so such
    /// a change goes unseen with probability 2^-63.
    fn digest(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |word: u64| h = mix(h, word);
        let mut vec = |v: Vec3| {
            v.to_array()
                .into_iter()
                .for_each(|x| eat(x.to_bits().into()))
        };
        vec(self.position);
        vec(self.normal);
        vec(self.irradiance);
        self.grad_t.iter().chain(&self.grad_r).for_each(|&g| vec(g));
        eat(self.radius.to_bits().into());
        eat(self.id.0);
        // Never zero, so an all-zero (unwritten) record is never intact.
        h | 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Record {
        Record::new(Vec3::new(1.0, 2.0, 3.0), Vec3::Z, Vec3::splat(0.5), 0.25)
    }

    #[test]
    #[should_panic(expected = "exceeds WorkerId::MAX")]
    fn worker_numbers_beyond_16_bits_are_refused() {
        let _ = WorkerId::new(WorkerId::MAX + 1);
    }

    #[test]
    fn worker_numbers_fill_16_bits() {
        assert_eq!(WorkerId::MAX, 65_535);
        let last = WorkerId::new(65_535);
        assert_eq!(last.index(), 65_535);
        assert_eq!(WorkerId::new(7).index(), 7);
        assert_eq!(last.to_string(), "worker 65535");
        // The largest worker survives packing into an id beside the largest frame and count.
        let id = RecordId::new(last, 0xffff, 0xffff_ffff);
        assert_eq!(id.worker(), last);
        assert_eq!(id.get(), u64::MAX);
    }

    #[test]
    fn record_id_packed_value() {
        let id = RecordId::new(WorkerId::new(2), 5, 9);
        assert_eq!(id.get(), (2 << 48) | (5 << 32) | 9);
        // Frames and counts wrap into their fields instead of spilling into the worker's.
        let wrapped = RecordId::new(WorkerId::new(2), 0x1_0005, 0x1_0000_0009);
        assert_eq!(wrapped, id);
    }

    #[test]
    fn zero_irradiance_is_valid() {
        // A record that saw no light (a dark corner) is a real sample, not an error.
        let dark = Record::new(Vec3::ZERO, Vec3::Z, Vec3::ZERO, 1.0);
        assert_eq!(dark.validate(), Ok(()));
    }

    /// The inverse of one step of the digest (`h = (h ^ w) * M; h ^= h >> 29`), written from the
    /// definition: undo the xor-shift, multiply by `M`'s inverse modulo 2^64, xor the word back.
    fn unmix(mut h: u64, word: u64) -> u64 {
        // x ^ (x >> 29) is undone by repeating the shift until it runs out of bits (3 * 29 > 64).
        let mut x = h;
        for _ in 0..3 {
            x = h ^ (x >> 29);
        }
        h = x;
        // Newton's iteration for the inverse of an odd number modulo 2^64.
        let m: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut inv: u64 = m;
        for _ in 0..6 {
            inv = inv.wrapping_mul(2u64.wrapping_sub(m.wrapping_mul(inv)));
        }
        assert_eq!(m.wrapping_mul(inv), 1);
        h.wrapping_mul(inv) ^ word
    }

    #[test]
    fn each_digest_step_is_a_bijection() {
        // The claim the torn-read check rests on: every step of the digest can be undone, so two
        // records that differ in one word never reach the last step with the same state.
        let mut state = 0x0123_4567_89ab_cdefu64;
        for k in 0..1000u64 {
            let word = k.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ (k << 40);
            let next = mix(state, word);
            assert_eq!(unmix(next, word), state, "step {k} cannot be undone");
            state = next;
        }
    }

    #[test]
    fn a_sealed_check_is_never_even() {
        // The last step sets the low bit, so no sealed record has check 0 (an unwritten slot's).
        for k in 0..64u64 {
            let r = Record::new(Vec3::splat(k as f32), Vec3::Z, Vec3::ONE, 1.0 + k as f32)
                .sealed(RecordId::new(WorkerId::new(1), 0, k));
            assert_eq!(r.check & 1, 1, "record {k}");
        }
    }

    #[test]
    fn record_id_packs_worker_and_sequence() {
        let id = RecordId::new(WorkerId::new(7), 3, 123_456);
        assert_eq!(id.worker(), WorkerId::new(7));
        assert_eq!((id.frame(), id.seq()), (3, 123_456));
        assert_eq!(id.to_string(), "r7.3.123456");
        assert_ne!(id, RecordId::new(WorkerId::new(7), 4, 123_456));
    }

    #[test]
    fn sealing_detects_any_changed_field() {
        let mut r = sample();
        assert!(!r.is_intact(), "an unsealed record must not pass");
        r.seal(RecordId::new(WorkerId::new(1), 0, 1));
        assert!(r.is_intact());
        let mut torn = r;
        torn.irradiance.y = 0.25;
        assert!(!torn.is_intact());
        let mut torn = r;
        torn.grad_r[2].x = 1e-9;
        assert!(!torn.is_intact());
        let mut torn = r;
        torn.id = RecordId::new(WorkerId::new(1), 0, 2);
        assert!(!torn.is_intact());
        // An all-zero record (what an unwritten slot would hold) is never intact.
        let zero = Record::new(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0);
        assert!(!zero.is_intact());
    }

    #[test]
    fn validation_names_the_bad_field() {
        assert_eq!(sample().validate(), Ok(()));
        let mut r = sample();
        r.position.x = f32::NAN;
        assert_eq!(
            r.validate(),
            Err(InsertError::NonFinite { field: "position" })
        );
        let mut r = sample();
        r.grad_t[1].z = f32::INFINITY;
        assert_eq!(
            r.validate(),
            Err(InsertError::NonFinite { field: "grad_t[1]" })
        );
        let mut r = sample();
        r.radius = 0.0;
        assert_eq!(r.validate(), Err(InsertError::NonPositiveRadius(0.0)));
        let mut r = sample();
        r.radius = f32::NAN;
        assert_eq!(
            r.validate(),
            Err(InsertError::NonFinite { field: "radius" })
        );
        let mut r = sample();
        r.normal = Vec3::new(0.0, 0.0, 2.0);
        assert_eq!(
            r.validate(),
            Err(InsertError::NormalNotUnit { length: 2.0 })
        );
        let mut r = sample();
        r.irradiance.z = -0.1;
        assert!(matches!(
            r.validate(),
            Err(InsertError::NegativeIrradiance(_))
        ));
        assert!(InsertError::NormalNotUnit { length: 2.0 }
            .to_string()
            .contains("length 2"));
    }
}
