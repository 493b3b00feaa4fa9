//! SE(2) poses: a position in metres and a heading, with compose, inverse and transform-point.

use crate::{cos, mul_unit, sin, BinaryAngle, Meters};

/// A pose in the plane: position `(x, y)` in metres and heading `theta` (REP-103: x forward,
/// y left, counter-clockwise positive). As a transform it maps points from the pose's own frame
/// into the frame the pose is expressed in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Pose2 {
    /// x, metres.
    pub x: Meters,
    /// y, metres.
    pub y: Meters,
    /// Heading.
    pub theta: BinaryAngle,
}

impl Pose2 {
    /// The identity transform.
    pub const IDENTITY: Self = Self { x: Meters::ZERO, y: Meters::ZERO, theta: BinaryAngle::ZERO };

    /// A pose from its parts.
    pub const fn new(x: Meters, y: Meters, theta: BinaryAngle) -> Self {
        Self { x, y, theta }
    }

    /// Maps a point from this pose's frame into the parent frame: `R(θ)·p + t`. Saturating.
    pub fn transform_point(&self, px: Meters, py: Meters) -> (Meters, Meters) {
        let (s, c) = (sin(self.theta), cos(self.theta));
        let x = self.x.saturating_add(mul_unit(px, c)).saturating_sub(mul_unit(py, s));
        let y = self.y.saturating_add(mul_unit(px, s)).saturating_add(mul_unit(py, c));
        (x, y)
    }

    /// `self ∘ other`: the pose `other` (expressed in this pose's frame) expressed in the parent frame.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let (x, y) = self.transform_point(other.x, other.y);
        Pose2 { x, y, theta: self.theta + other.theta }
    }

    /// The inverse transform: `(−Rᵀ t, −θ)`, so `p.compose(&p.inverse())` is the identity up to
    /// rounding (a few 2⁻¹⁶ m).
    pub fn inverse(&self) -> Pose2 {
        let (s, c) = (sin(self.theta), cos(self.theta));
        // Rᵀ = [[c, s], [−s, c]]
        let x = mul_unit(self.x, c).saturating_add(mul_unit(self.y, s)).saturating_neg();
        let y = mul_unit(self.x, s).saturating_sub(mul_unit(self.y, c));
        Pose2 { x, y, theta: -self.theta }
    }

    /// From `f64` metres and radians (the boundary); `None` if any part is not finite or too large.
    pub fn from_f64(x: f64, y: f64, theta_rad: f64) -> Option<Pose2> {
        Some(Pose2 { x: crate::meters_from_f64(x)?, y: crate::meters_from_f64(y)?, theta: BinaryAngle::from_radians(theta_rad)? })
    }

    /// To `f64` metres and radians, for rendering and logs.
    pub fn to_f64(&self) -> (f64, f64, f64) {
        (self.x.to_num::<f64>(), self.y.to_num::<f64>(), self.theta.to_radians())
    }
}
