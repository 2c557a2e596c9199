//! A pinhole camera and the orbit path of the paper's animations (§4.2).

use glam::{Vec2, Vec3};

/// A pinhole camera: eye, target, up vector and vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Point the camera looks at.
    pub target: Vec3,
    /// Approximate up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub vfov_degrees: f32,
}

/// A circle the camera orbits on (the paper's 360° walkthroughs), kept inside enclosed scenes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// Centre of the circle (the camera looks at it, at `look_height`).
    pub center: Vec3,
    /// Radius of the circle.
    pub radius: f32,
    /// Height (y) of the point looked at; the eye stays at `center.y`.
    pub look_height: f32,
    /// Vertical field of view in degrees.
    pub vfov_degrees: f32,
}

/// The camera's orthonormal frame and image-plane scale, precomputed for a frame.
#[derive(Clone, Copy, Debug)]
pub struct View {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half: f32,
    width: u32,
    height: u32,
}

impl Camera {
    /// A camera at `eye` looking at `target`.
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3, vfov_degrees: f32) -> Self {
        Self {
            eye,
            target,
            up,
            vfov_degrees,
        }
    }

    /// The camera at time `t` of an orbit: `t = 0` and `t = 1` are the same position, one full turn
    /// about the vertical (y) axis through `orbit.center` in between, looking at the centre.
    pub fn on_orbit(orbit: &Orbit, t: f32) -> Self {
        let angle = std::f32::consts::TAU * t;
        let eye = orbit.center + orbit.radius * Vec3::new(angle.sin(), 0.0, -angle.cos());
        let mut target = orbit.center;
        target.y = orbit.look_height;
        // Look across the centre, so the far side of the room fills the frame.
        let target = eye + (target - eye) * 2.0;
        Self::look_at(eye, target, Vec3::Y, orbit.vfov_degrees)
    }

    /// The frame for a `width` x `height` image.
    pub fn view(&self, width: u32, height: u32) -> View {
        let forward = (self.target - self.eye).normalize();
        // Looking along `up` leaves the roll undefined: fall back to another axis.
        let up = if forward.cross(self.up).length_squared() > 1e-8 {
            self.up
        } else {
            forward.any_orthonormal_vector()
        };
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        View {
            eye: self.eye,
            forward,
            right,
            up,
            tan_half: (self.vfov_degrees.to_radians() * 0.5).tan(),
            width,
            height,
        }
    }
}

impl View {
    /// The eye.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// The unit direction through image position `(x, y)` in pixels (`(0, 0)` the top-left
    /// corner, pixel centres at `+0.5`).
    pub fn direction(&self, x: f32, y: f32) -> Vec3 {
        let (w, h) = (self.width as f32, self.height as f32);
        let sx = (2.0 * x / w - 1.0) * self.tan_half * (w / h);
        let sy = (1.0 - 2.0 * y / h) * self.tan_half;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }

    /// The side of one pixel at distance `t` along the unit ray `dir`: the pixel footprint the
    /// cache's radius clamps are measured in.
    pub fn footprint(&self, t: f32, dir: Vec3) -> f32 {
        let depth = t * dir.dot(self.forward);
        depth * 2.0 * self.tan_half / self.height as f32
    }

    /// Where `p` lands on the image, in pixels, or `None` when it is behind the eye or outside.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        if z <= 1e-6 {
            return None;
        }
        let (w, h) = (self.width as f32, self.height as f32);
        let sx = d.dot(self.right) / (z * self.tan_half * (w / h));
        let sy = d.dot(self.up) / (z * self.tan_half);
        let px = (sx + 1.0) * 0.5 * w;
        let py = (1.0 - sy) * 0.5 * h;
        (px >= 0.0 && px < w && py >= 0.0 && py < h).then_some(Vec2::new(px, py))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_inverts_the_primary_ray() {
        let cam = Camera::look_at(Vec3::new(1.0, 2.0, -5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let view = cam.view(64, 48);
        for &(x, y) in &[(0.5, 0.5), (31.5, 20.5), (63.5, 47.5)] {
            let p = view.eye() + view.direction(x, y) * 3.7;
            let q = view.project(p).unwrap();
            assert!((q - Vec2::new(x, y)).length() < 1e-3, "{q} vs {x},{y}");
        }
        assert_eq!(view.project(view.eye() - view.direction(32.0, 24.0)), None);
        // Looking straight down still gives a frame.
        let down = Camera::look_at(Vec3::Y, Vec3::ZERO, Vec3::Y, 40.0).view(8, 8);
        assert!(down.direction(4.0, 4.0).is_finite());
        assert!((down.direction(4.0, 4.0) + Vec3::Y).length() < 1e-5);
    }

    #[test]
    fn orbit_closes_and_moves() {
        let orbit = Orbit {
            center: Vec3::new(0.0, 1.0, 0.0),
            radius: 2.0,
            look_height: 0.5,
            vfov_degrees: 50.0,
        };
        let a = Camera::on_orbit(&orbit, 0.0);
        let b = Camera::on_orbit(&orbit, 1.0);
        let c = Camera::on_orbit(&orbit, 0.5);
        assert!((a.eye - b.eye).length() < 1e-4);
        assert!((a.eye - c.eye).length() > 3.9);
        assert!(((a.eye - orbit.center).length() - 2.0).abs() < 1e-4);
    }
}
