//! Which records a removal takes out: the cache-independent half of removal (the caches walk their
//! trees and call [`Selection::selects`] on each record they meet).
//!
//! Two kinds, what a renderer of a dynamic scene needs:
//! * [`Selection::touching`]: every record whose *influence sphere* — centre `x_i`, radius
//!   `a R_i` ([`super::influence_radius`]), the region where it can be valid — meets a box. Give
//!   it the swept bounds of an object that moved. It is a local test: it takes out the records
//!   whose valid region the object entered or left, not those the object shadows or lights from
//!   farther away, which no local test can find (`paper-notes.md`, removal).
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
    Touching { min: Vec3, max: Vec3, margin: f32 },
    OlderThan { frames: u16 },
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
            Kind::OlderThan { frames } => write!(f, "older than {frames} frames"),
        }
    }
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
                // Squared distance from the centre to the box: zero inside it.
                let nearest = record.position.clamp(min, max);
                let reach = influence_radius(record, accuracy) + margin;
                (record.position - nearest).length_squared() <= reach * reach
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
            Kind::Touching { min, max, margin } => {
                !((hi + margin).cmplt(min).any() || (lo - margin).cmpgt(max).any())
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
    }
}
