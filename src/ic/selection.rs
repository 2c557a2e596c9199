//! Which records a removal takes out: the cache-independent half of removal (the caches walk their
//! trees and call [`Selection::selects`] on each record they meet).
//!
//! Two kinds, what a renderer of a dynamic scene needs:
//! * [`Selection::touching`]: every record whose *influence sphere* — centre `x_i`, radius
//!   `a R_i` ([`super::influence_radius`]), the region where it can be valid — meets a box. Give
//!   it the swept bounds of an object that moved. It is a local test: it takes out the records
//!   whose valid region the object entered or left, not those the object shadows or lights from
//!   farther away, which no local test can find (`docs/renderer.md`, dynamic scenes).
//! * [`Selection::near`]: the same with every sphere grown by a margin, for an object whose light
//!   and shadow reach farther than the records' own influence.
//! * [`Selection::moving`]: for an object that moves a known step a frame, a margin that grows
//!   with how far the object has moved *since each record was computed*: a record beside the
//!   object goes every frame, one farther away only once the object has moved far enough to
//!   change what it sees by more than a tolerance.
//! * [`Selection::older_than`]: every record inserted more than `n` frames before the frame the
//!   removal runs in, for caches that are refreshed by age.

use super::{influence_radius, Record};
use glam::Vec3;
use std::fmt;

/// Which records a removal takes out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Selection(Kind);

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Touching {
        min: Vec3,
        max: Vec3,
        margin: f32,
    },
    /// An object now in `[min, max]` that moved by `step` in each of the last `frames` frames
    /// (and stood still before); `k = size / (pi tolerance)`, its face's edge over the tolerated
    /// change, so that the margin at displacement `d` is `sqrt(min(d, size) k)`.
    Moving {
        min: Vec3,
        max: Vec3,
        step: Vec3,
        frames: u16,
        size: f32,
        k: f32,
    },
    OlderThan {
        frames: u16,
    },
}

/// A selection that could not be made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SelectionError {
    /// A corner of the box is not finite.
    NonFiniteBox {
        /// The corner given as the minimum.
        min: Vec3,
        /// The corner given as the maximum.
        max: Vec3,
    },
    /// The minimum corner exceeds the maximum on some axis.
    InvertedBox {
        /// The corner given as the minimum.
        min: Vec3,
        /// The corner given as the maximum.
        max: Vec3,
    },
    /// A margin that is negative or not finite.
    BadMargin(f32),
    /// A step that is not finite.
    BadStep(Vec3),
    /// A tolerance that is not a finite fraction above 0.
    BadTolerance(f32),
}

impl fmt::Display for SelectionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFiniteBox { min, max } => {
                write!(f, "removal box {min} .. {max} has a corner that is not finite")
            }
            Self::InvertedBox { min, max } => write!(
                f,
                "removal box {min} .. {max} is inverted: its minimum exceeds its maximum on some axis"
            ),
            Self::BadMargin(m) => {
                write!(f, "removal margin {m} is not a finite distance of 0 or more")
            }
            Self::BadStep(s) => write!(f, "removal step {s} is not a finite displacement"),
            Self::BadTolerance(t) => {
                write!(f, "removal tolerance {t} is not a finite fraction above 0")
            }
        }
    }
}

impl std::error::Error for SelectionError {}

impl fmt::Display for Selection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Kind::Touching { min, max, margin } => {
                if min == max {
                    write!(f, "touching ({:.2},{:.2},{:.2})", min.x, min.y, min.z)?;
                } else {
                    write!(
                        f,
                        "touching ({:.2},{:.2},{:.2})..({:.2},{:.2},{:.2})",
                        min.x, min.y, min.z, max.x, max.y, max.z
                    )?;
                }
                if margin > 0.0 {
                    write!(f, " + {margin:.2}")?;
                }
                Ok(())
            }
            Kind::Moving {
                min,
                max,
                step,
                frames,
                size,
                k,
            } => write!(
                f,
                "moving ({:.2},{:.2},{:.2})..({:.2},{:.2},{:.2}) by ({:.3},{:.3},{:.3}) a frame \
                 for {frames} frames, tolerance {:.2}",
                min.x,
                min.y,
                min.z,
                max.x,
                max.y,
                max.z,
                step.x,
                step.y,
                step.z,
                size / (std::f32::consts::PI * k)
            ),
            Kind::OlderThan { frames } => write!(f, "older than {frames} frames"),
        }
    }
}

/// For [`Kind::Moving`] and a record `age` frames old: the box the object swept since (it was at
/// `[min, max] - age step` then) and the margin at its displacement.
#[inline]
fn swept(min: Vec3, max: Vec3, step: Vec3, size: f32, k: f32, age: f32) -> (Vec3, Vec3, f32) {
    let shift = step * age;
    (
        min.min(min - shift),
        max.max(max - shift),
        (shift.length().min(size) * k).sqrt(),
    )
}

/// Whether the cube `[lo, hi]`, grown by `margin`, meets the box `[min, max]`.
#[inline]
fn cell_may_reach(lo: Vec3, hi: Vec3, min: Vec3, max: Vec3, margin: f32) -> bool {
    !((hi + margin).cmplt(min).any() || (lo - margin).cmpgt(max).any())
}

/// Distance from `p` to the closed box `[min, max]`, squared (zero inside it).
#[inline]
fn to_box_squared(p: Vec3, min: Vec3, max: Vec3) -> f32 {
    (p - p.clamp(min, max)).length_squared()
}

/// Frames are numbered modulo 2^16 in record ids ([`super::RecordId::frame`]).
const FRAME_MASK: u64 = 0xffff;

impl Selection {
    /// The records whose influence sphere meets the closed box `[min, max]`.
    ///
    /// # Errors
    /// A corner that is not finite, or a minimum above the maximum on some axis.
    pub fn touching(min: Vec3, max: Vec3) -> Result<Self, SelectionError> {
        if !(min.is_finite() && max.is_finite()) {
            return Err(SelectionError::NonFiniteBox { min, max });
        }
        if min.cmpgt(max).any() {
            return Err(SelectionError::InvertedBox { min, max });
        }
        Ok(Self(Kind::Touching {
            min,
            max,
            margin: 0.0,
        }))
    }

    /// The records whose influence sphere, grown by `margin`, meets the closed box `[min, max]`:
    /// for a moved object whose effect reaches farther than the records' own influence (a record
    /// beside a moved block sees it fill part of its hemisphere, however small its radius). An
    /// object that fills a solid angle `A / d^2` of a point's view changes its irradiance by
    /// about `A / (pi d^2)` of itself; at `margin = sqrt(A / (pi a))` that is the cache's own
    /// accuracy `a`.
    ///
    /// # Errors
    /// As [`Selection::touching`], and a margin that is negative or not finite.
    pub fn near(min: Vec3, max: Vec3, margin: f32) -> Result<Self, SelectionError> {
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(SelectionError::BadMargin(margin));
        }
        let Self(Kind::Touching { .. }) = Self::touching(min, max)? else {
            unreachable!("touching makes a box selection")
        };
        Ok(Self(Kind::Touching { min, max, margin }))
    }

    /// For an object that is now in the box `[min, max]` and moved by `step` in each of the last
    /// `frames` frames (standing still before): the records whose light it changed by more than
    /// `tolerance` (a fraction; give the cache's accuracy `a`) since they were computed.
    ///
    /// A record computed `age` frames ago (counted up to `frames`) saw the object displaced by
    /// `d = |step| age` from where it is now, somewhere in the box swept between the two places.
    /// Seen from a point at distance `r`, a face of edge `s` (the square root of the bounds'
    /// largest face) that moves by `d` across the view uncovers and covers about `d s` of area on
    /// each side, at most its own `s^2` once `d >= s`: a change of about `min(d, s) s / (pi r^2)`
    /// of the point's irradiance. The record is taken when its influence sphere, grown by the
    /// `r` at which that equals `tolerance`, `sqrt(min(d, s) s / (pi tolerance))`, meets the swept
    /// box. A record beside the object goes every frame; one farther away only when the object has
    /// moved far enough since it was computed; one computed in the frame the removal runs in
    /// (`age` 0, with the object where it is now) never. Once `d >= s` the margin is
    /// [`Selection::near`]'s, `sqrt(A / (pi a))`.
    ///
    /// # Errors
    /// As [`Selection::touching`]; a step that is not finite; a tolerance that is not a finite
    /// number above 0.
    pub fn moving(
        min: Vec3,
        max: Vec3,
        step: Vec3,
        frames: u16,
        tolerance: f32,
    ) -> Result<Self, SelectionError> {
        Self::touching(min, max)?;
        if !step.is_finite() {
            return Err(SelectionError::BadStep(step));
        }
        if !(tolerance.is_finite() && tolerance > 0.0) {
            return Err(SelectionError::BadTolerance(tolerance));
        }
        let e = max - min;
        let size = (e.x * e.y).max(e.y * e.z).max(e.x * e.z).sqrt();
        Ok(Self(Kind::Moving {
            min,
            max,
            step,
            frames,
            size,
            k: size / (std::f32::consts::PI * tolerance),
        }))
    }

    /// The records inserted more than `frames` frames before the frame the removal runs in
    /// (`older_than(0)`: every record of an earlier frame). Record ids hold the frame modulo
    /// 2^16, so an age is known modulo 2^16: a cache that removes by age every frame never holds
    /// a record old enough to wrap.
    pub fn older_than(frames: u16) -> Self {
        Self(Kind::OlderThan { frames })
    }

    /// Whether this selection takes `record` out of a cache of accuracy `accuracy`, in frame
    /// `now` (the number of frames the cache has closed).
    #[inline]
    pub fn selects(&self, record: &Record, accuracy: f32, now: u64) -> bool {
        match self.0 {
            Kind::Touching { min, max, margin } => {
                let reach = influence_radius(record, accuracy) + margin;
                to_box_squared(record.position, min, max) <= reach * reach
            }
            Kind::Moving {
                min,
                max,
                step,
                frames,
                size,
                k,
            } => {
                let age =
                    (now.wrapping_sub(record.id().frame()) & FRAME_MASK).min(u64::from(frames));
                if age == 0 {
                    // Computed with the object where it is now.
                    return false;
                }
                let (lo, hi, margin) = swept(min, max, step, size, k, age as f32);
                let reach = influence_radius(record, accuracy) + margin;
                to_box_squared(record.position, lo, hi) <= reach * reach
            }
            Kind::OlderThan { frames } => {
                let age = now.wrapping_sub(record.id().frame()) & FRAME_MASK;
                age > u64::from(frames)
            }
        }
    }

    /// Whether a record whose influence sphere lies inside the axis-aligned cube `[lo, hi]` can
    /// be selected (false: a tree walk may skip the node whose loose cell that is, and, loose
    /// cells nesting, its whole subtree).
    #[inline]
    pub fn may_select_within(&self, lo: Vec3, hi: Vec3) -> bool {
        match self.0 {
            Kind::Touching { min, max, margin } => cell_may_reach(lo, hi, min, max, margin),
            Kind::Moving {
                min,
                max,
                step,
                frames,
                size,
                k,
            } => {
                // The oldest records' swept box and margin hold every younger record's.
                let (min, max, margin) = swept(min, max, step, size, k, f32::from(frames));
                cell_may_reach(lo, hi, min, max, margin)
            }
            Kind::OlderThan { .. } => true,
        }
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use crate::ic::{RecordId, WorkerId};

    fn at(p: Vec3, radius: f32, frame: u64) -> Record {
        Record::new(p, Vec3::Z, Vec3::ONE, radius).sealed(RecordId::new(WorkerId::new(0), frame, 0))
    }

    #[test]
    fn touching_tests_the_influence_sphere_against_the_box() {
        let s = Selection::touching(Vec3::ZERO, Vec3::ONE).unwrap();
        // Radius 2 at a = 0.5: influence 1. Centre 1.9 beyond the face x = 1: misses; 0.9: meets.
        assert!(!s.selects(&at(Vec3::new(2.9, 0.5, 0.5), 2.0, 0), 0.5, 0));
        assert!(s.selects(&at(Vec3::new(1.9, 0.5, 0.5), 2.0, 0), 0.5, 0));
        // Inside the box, however small the sphere.
        assert!(s.selects(&at(Vec3::splat(0.5), 0.01, 0), 0.5, 0));
        // Beside a corner: distance sqrt(3) * 0.6 = 1.04 > 1 misses, sqrt(3) * 0.5 = 0.87 meets.
        assert!(!s.selects(&at(Vec3::splat(1.6), 2.0, 0), 0.5, 0));
        assert!(s.selects(&at(Vec3::splat(1.5), 2.0, 0), 0.5, 0));
        // The accuracy scales the sphere: at a = 0.25 the 0.9 record misses.
        assert!(!s.selects(&at(Vec3::new(1.9, 0.5, 0.5), 2.0, 0), 0.25, 0));
    }

    #[test]
    fn older_than_counts_frames_modulo_the_id() {
        let s = Selection::older_than(2);
        assert!(!s.selects(&at(Vec3::ZERO, 1.0, 10), 0.5, 12));
        assert!(s.selects(&at(Vec3::ZERO, 1.0, 9), 0.5, 12));
        // Frame 65 535 seen from frame 65 537 (id frame 1): age 2, not older than 2.
        assert!(!s.selects(&at(Vec3::ZERO, 1.0, 65_535), 0.5, 65_537));
        assert!(Selection::older_than(0).selects(&at(Vec3::ZERO, 1.0, 3), 0.5, 4));
        assert!(!Selection::older_than(0).selects(&at(Vec3::ZERO, 1.0, 4), 0.5, 4));
    }

    #[test]
    fn bad_boxes_are_refused_by_name() {
        let e = Selection::touching(Vec3::ONE, Vec3::ZERO).unwrap_err();
        assert!(matches!(e, SelectionError::InvertedBox { .. }));
        assert!(e.to_string().contains("inverted"), "{e}");
        let e = Selection::touching(Vec3::ZERO, Vec3::new(1.0, f32::NAN, 1.0)).unwrap_err();
        assert!(matches!(e, SelectionError::NonFiniteBox { .. }));
        assert!(e.to_string().contains("not finite"), "{e}");
        // A flat box (a plane's swept bounds) is fine.
        assert!(Selection::touching(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0)).is_ok());
    }

    #[test]
    fn a_margin_grows_every_influence_sphere() {
        // Influence 1 (radius 2, a = 0.5), centre 1.9 beyond the face x = 1: missed by the box,
        // met with a margin of 0.9 or more.
        let r = at(Vec3::new(2.9, 0.5, 0.5), 2.0, 0);
        assert!(!Selection::touching(Vec3::ZERO, Vec3::ONE)
            .unwrap()
            .selects(&r, 0.5, 0));
        assert!(!Selection::near(Vec3::ZERO, Vec3::ONE, 0.85)
            .unwrap()
            .selects(&r, 0.5, 0));
        assert!(Selection::near(Vec3::ZERO, Vec3::ONE, 0.95)
            .unwrap()
            .selects(&r, 0.5, 0));
        // The subtree test grows with it.
        let s = Selection::near(Vec3::ZERO, Vec3::ONE, 0.5).unwrap();
        assert!(s.may_select_within(Vec3::new(1.4, 0.0, 0.0), Vec3::splat(3.0)));
        assert!(!s.may_select_within(Vec3::new(1.6, 0.0, 0.0), Vec3::splat(3.0)));
        // And on the low side of the box.
        assert!(s.may_select_within(Vec3::splat(-3.0), Vec3::new(-0.4, 3.0, 3.0)));
        assert!(!s.may_select_within(Vec3::splat(-3.0), Vec3::new(-0.6, 3.0, 3.0)));
        let e = Selection::near(Vec3::ZERO, Vec3::ONE, -1.0).unwrap_err();
        assert_eq!(e, SelectionError::BadMargin(-1.0));
        assert!(e.to_string().contains("margin"), "{e}");
        assert!(Selection::near(Vec3::ONE, Vec3::ZERO, 1.0).is_err());
        assert_eq!(
            s.to_string(),
            "touching (0.00,0.00,0.00)..(1.00,1.00,1.00) + 0.50"
        );
    }

    #[test]
    fn a_region_beside_the_box_cannot_hold_a_selected_record() {
        let s = Selection::touching(Vec3::ZERO, Vec3::ONE).unwrap();
        assert!(s.may_select_within(Vec3::splat(0.5), Vec3::splat(3.0)));
        assert!(s.may_select_within(Vec3::splat(1.0), Vec3::splat(3.0)));
        assert!(!s.may_select_within(Vec3::new(1.1, 0.0, 0.0), Vec3::splat(3.0)));
        assert!(!s.may_select_within(Vec3::splat(-3.0), Vec3::new(-0.1, 3.0, 3.0)));
        assert!(Selection::older_than(1).may_select_within(Vec3::splat(9.0), Vec3::splat(10.0)));
        // Without a margin the box prints bare; a point box prints as its point.
        assert_eq!(s.to_string(), "touching (0.00,0.00,0.00)..(1.00,1.00,1.00)");
        let point = Selection::touching(Vec3::ONE, Vec3::ONE).unwrap();
        assert_eq!(point.to_string(), "touching (1.00,1.00,1.00)");
    }

    #[test]
    fn moving_grows_the_margin_with_the_motion_since_the_record() {
        // The unit cube (edge 1) moving +0.1 in x a frame for 10 frames, tolerance 0.25: the
        // margin at age n is sqrt(min(0.1 n, 1) / (pi 0.25)): 0.357 at 1, 0.505 at 2, 1.128 from
        // 10 on. Records of radius 0.01 (influence 0.0025 at a = 0.25), made in frame 0.
        let s =
            Selection::moving(Vec3::ZERO, Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), 10, 0.25).unwrap();
        let above = |r: f32| at(Vec3::new(0.5, 1.0 + r, 0.5), 0.01, 0);
        // Made in the frame the removal runs in: never, even inside the box.
        assert!(!s.selects(&at(Vec3::splat(0.5), 0.01, 7), 0.25, 7));
        // Beside the box: taken after a frame.
        assert!(s.selects(&above(0.3), 0.25, 1));
        // 0.5 above: not after one frame, after two.
        assert!(!s.selects(&above(0.5), 0.25, 1));
        assert!(s.selects(&above(0.5), 0.25, 2));
        // 1.2 above: never, however old (the margin stops at the face's own area).
        assert!(!s.selects(&above(1.2), 0.25, 10));
        let long =
            Selection::moving(Vec3::ZERO, Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), 40, 0.25).unwrap();
        assert!(!long.selects(&above(1.2), 0.25, 40));
        assert!(s.selects(&above(1.1), 0.25, 10));
        // The swept box: 0.9 behind the box (where it came from) is taken at age 5 (the old place
        // reaches x = -0.5, 0.4 away, within 0.798), 0.85 in front of it is not.
        let behind = at(Vec3::new(-0.9, 0.5, 0.5), 0.01, 0);
        assert!(!s.selects(&behind, 0.25, 1));
        assert!(s.selects(&behind, 0.25, 5));
        assert!(!s.selects(&at(Vec3::new(1.85, 0.5, 0.5), 0.01, 0), 0.25, 5));
        // Ages count up to `frames` only: the object stood still before. At 3 frames, 0.5 above
        // is taken at age 3 or 30 (margin 0.618); at 1 frame, at no age.
        let three =
            Selection::moving(Vec3::ZERO, Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), 3, 0.25).unwrap();
        assert!(three.selects(&above(0.5), 0.25, 30));
        let one =
            Selection::moving(Vec3::ZERO, Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), 1, 0.25).unwrap();
        assert!(!one.selects(&above(0.5), 0.25, 30));
        assert!(!one.selects(&behind, 0.25, 30));
        // A looser tolerance shrinks the margin: at 0.5, 0.3 above is kept after one frame (0.252).
        let loose =
            Selection::moving(Vec3::ZERO, Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), 10, 0.5).unwrap();
        assert!(!loose.selects(&above(0.3), 0.25, 1));
    }

    #[test]
    fn moving_measures_the_largest_face_of_a_box_anywhere() {
        // Boxes off the origin, each with a different largest face (area 8, edge sqrt 8 = 2.83;
        // the other faces 4 and 2), moved 10 in x in one frame: once the motion exceeds the edge
        // the margin is `sqrt(s s / (pi tolerance))`, `s` itself at tolerance 1/pi. A record of
        // negligible sphere 2.5 above the box is taken (a margin from a smaller face, 2, would
        // keep it), one 3.2 above is not (a box measured from the origin, not its own corner,
        // would be larger).
        let tol = std::f32::consts::FRAC_1_PI;
        let step = Vec3::new(10.0, 0.0, 0.0);
        for dims in [
            Vec3::new(4.0, 2.0, 1.0),
            Vec3::new(1.0, 4.0, 2.0),
            Vec3::new(4.0, 1.0, 2.0),
        ] {
            let (min, max) = (Vec3::ONE, Vec3::ONE + dims);
            let s = Selection::moving(min, max, step, 1, tol).unwrap();
            let above = |h: f32| at(Vec3::new(max.x - 0.5, max.y + h, max.z - 0.5), 0.01, 0);
            assert!(s.selects(&above(2.5), 0.25, 1), "{dims}");
            assert!(!s.selects(&above(3.2), 0.25, 1), "{dims}");
        }
        // The record's own sphere adds to the margin: influence 2 (radius 4 at a = 0.5) reaches
        // from 4.3 above the box (2.83 + 2 > 4.3), not from 5.
        let (min, max) = (Vec3::ONE, Vec3::new(5.0, 3.0, 2.0));
        let s = Selection::moving(min, max, step, 1, tol).unwrap();
        assert!(s.selects(&at(Vec3::new(3.0, 3.0 + 4.3, 1.5), 4.0, 0), 0.5, 1));
        assert!(!s.selects(&at(Vec3::new(3.0, 3.0 + 5.0, 1.5), 4.0, 0), 0.5, 1));
    }

    #[test]
    fn moving_bounds_its_subtrees_by_its_oldest_records() {
        let s =
            Selection::moving(Vec3::ZERO, Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), 10, 0.25).unwrap();
        // Swept box x in [-1, 1], margin 1.128: a cell from x = -2.1 to -2.2 is out of reach, one
        // reaching -2.0 is not; in front, 2.1 is out, 2.0 is not.
        assert!(!s.may_select_within(Vec3::new(-3.0, 0.0, 0.0), Vec3::new(-2.2, 1.0, 1.0)));
        assert!(s.may_select_within(Vec3::new(-3.0, 0.0, 0.0), Vec3::new(-2.0, 1.0, 1.0)));
        assert!(!s.may_select_within(Vec3::new(2.2, 0.0, 0.0), Vec3::new(3.0, 1.0, 1.0)));
        assert!(s.may_select_within(Vec3::new(2.1, 0.0, 0.0), Vec3::new(3.0, 1.0, 1.0)));
        // Every record the selection takes lies in a cell the bound keeps: a grid of records and
        // ages, each in the cell of its own sphere.
        for ix in -30..30 {
            for iy in -10..25 {
                for age in 0..14 {
                    let p = Vec3::new(ix as f32 * 0.1, iy as f32 * 0.1, 0.5);
                    let r = at(p, 0.4, 0);
                    let reach = influence_radius(&r, 0.25);
                    if s.selects(&r, 0.25, age) {
                        assert!(
                            s.may_select_within(p - reach, p + reach),
                            "{p} at age {age}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn moving_refuses_what_it_cannot_measure() {
        let z = Vec3::ZERO;
        assert!(matches!(
            Selection::moving(Vec3::ONE, z, z, 1, 0.25),
            Err(SelectionError::InvertedBox { .. })
        ));
        let e =
            Selection::moving(z, Vec3::ONE, Vec3::new(f32::NAN, 0.0, 0.0), 1, 0.25).unwrap_err();
        assert!(matches!(e, SelectionError::BadStep(_)));
        assert!(e.to_string().contains("step"), "{e}");
        for t in [0.0, -0.1, f32::NAN, f32::INFINITY] {
            let e = Selection::moving(z, Vec3::ONE, z, 1, t).unwrap_err();
            assert!(matches!(e, SelectionError::BadTolerance(_)), "{t}");
            assert!(e.to_string().contains("tolerance"), "{e}");
        }
        let s = Selection::moving(z, Vec3::ONE, Vec3::new(0.1, 0.0, 0.0), 4, 0.25).unwrap();
        assert_eq!(
            s.to_string(),
            "moving (0.00,0.00,0.00)..(1.00,1.00,1.00) by (0.100,0.000,0.000) a frame for 4 frames, tolerance 0.25"
        );
    }
}
