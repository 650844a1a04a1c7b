//! Plane geometry: vectors, poses, body twists and ray–shape intersections.
//!
//! Frames: the world frame is fixed (x east, y north, angles counter-clockwise from +x); a
//! robot's body frame has +x forward and +y to the left. Distances in metres, angles in radians.

use std::ops::{Add, Mul, Neg, Sub};

/// A point or vector in the plane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec2 {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
}

impl Vec2 {
    /// `(x, y)`.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// The unit vector at angle `a` from +x.
    pub fn from_angle(a: f64) -> Self {
        Self::new(a.cos(), a.sin())
    }

    /// Dot product.
    pub fn dot(self, o: Self) -> f64 {
        self.x * o.x + self.y * o.y
    }

    /// z component of the cross product (`self × o`).
    pub fn cross(self, o: Self) -> f64 {
        self.x * o.y - self.y * o.x
    }

    /// Euclidean length.
    pub fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }

    /// `self` rotated counter-clockwise by `a`.
    pub fn rotated(self, a: f64) -> Self {
        let (s, c) = a.sin_cos();
        Self::new(c * self.x - s * self.y, s * self.x + c * self.y)
    }
}

impl Add for Vec2 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y)
    }
}

impl Sub for Vec2 {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y)
    }
}

impl Neg for Vec2 {
    type Output = Self;
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y)
    }
}

impl Mul<f64> for Vec2 {
    type Output = Self;
    fn mul(self, k: f64) -> Self {
        Self::new(self.x * k, self.y * k)
    }
}

/// `a` wrapped into (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let w = a.rem_euclid(TAU);
    if w > PI {
        w - TAU
    } else {
        w
    }
}

/// A position and heading.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
    /// Heading, rad, wrapped into (−π, π].
    pub theta: f64,
}

impl Pose {
    /// `(x, y, theta)`.
    pub const fn new(x: f64, y: f64, theta: f64) -> Self {
        Self { x, y, theta }
    }

    /// The position.
    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x, self.y)
    }

    /// The pose of a frame mounted at `local` (given in this pose's frame), in this pose's
    /// parent frame: a sensor's world pose from the base pose and its mount pose.
    pub fn compose(&self, local: &Pose) -> Pose {
        let p = self.position() + local.position().rotated(self.theta);
        Pose::new(p.x, p.y, wrap_angle(self.theta + local.theta))
    }

    /// Moves the pose by the body twist `t` held constant for `dt` seconds, exactly (the
    /// SE(2) exponential: a straight line or a circular arc), so that the integration adds no
    /// error of its own however long the step.
    pub fn integrate(&mut self, t: &Twist, dt: f64) {
        let dth = t.wz * dt;
        // sin(dθ)/ω and (1 − cos dθ)/ω, with their series where dθ is tiny (cancellation).
        let (s, c) = if dth.abs() < 1e-6 {
            (dt * (1.0 - dth * dth / 6.0), dt * dth / 2.0)
        } else {
            (dth.sin() / t.wz, (1.0 - dth.cos()) / t.wz)
        };
        let body = Vec2::new(s * t.vx - c * t.vy, c * t.vx + s * t.vy);
        let d = body.rotated(self.theta);
        self.x += d.x;
        self.y += d.y;
        self.theta = wrap_angle(self.theta + dth);
    }
}

/// A planar velocity in the body frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Twist {
    /// Forward, m/s.
    pub vx: f64,
    /// Left, m/s.
    pub vy: f64,
    /// Counter-clockwise, rad/s.
    pub wz: f64,
}

impl Twist {
    /// `(vx, vy, wz)`.
    pub const fn new(vx: f64, vy: f64, wz: f64) -> Self {
        Self { vx, vy, wz }
    }

    /// Velocity of the body point `p` (body frame), in the body frame.
    pub fn point_velocity(&self, p: Vec2) -> Vec2 {
        Vec2::new(self.vx - self.wz * p.y, self.vy + self.wz * p.x)
    }
}

/// A half-line from `origin` along the unit vector `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: Vec2,
    /// Unit direction.
    pub dir: Vec2,
}

impl Ray {
    /// The ray from `origin` at angle `angle` (world frame).
    pub fn new(origin: Vec2, angle: f64) -> Self {
        Self { origin, dir: Vec2::from_angle(angle) }
    }

    /// Distance along the ray to the circle (`center`, `radius`): 0 if the origin is inside.
    pub fn hit_circle(&self, center: Vec2, radius: f64) -> Option<f64> {
        let w = self.origin - center;
        let b = w.dot(self.dir);
        let c = w.dot(w) - radius * radius;
        if c <= 0.0 {
            return Some(0.0);
        }
        let disc = b * b - c;
        if disc < 0.0 || b > 0.0 {
            return None; // misses, or the circle is behind the origin
        }
        Some(-b - disc.sqrt())
    }

    /// Distance along the ray to the segment `a`–`b` (a wall of no thickness). A ray running
    /// along the segment hits its nearer end (0 if the origin is on it).
    pub fn hit_segment(&self, a: Vec2, b: Vec2) -> Option<f64> {
        let e = b - a;
        let den = self.dir.cross(e);
        let ao = a - self.origin;
        // Collinear within rounding of the lengths involved.
        let scale = e.norm().max(ao.norm()).max(1.0);
        if den.abs() <= 1e-12 * scale {
            if ao.cross(self.dir).abs() > 1e-12 * scale {
                return None; // parallel, apart
            }
            let (ta, tb) = (ao.dot(self.dir), (b - self.origin).dot(self.dir));
            if ta.max(tb) < 0.0 {
                return None;
            }
            return Some(ta.min(tb).max(0.0));
        }
        let t = ao.cross(e) / den;
        let s = ao.cross(self.dir) / den;
        (t >= 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
    }

    /// Distance along the ray to the axis-aligned box `min`–`max` (slab method): 0 if the
    /// origin is inside.
    pub fn hit_aabb(&self, min: Vec2, max: Vec2) -> Option<f64> {
        let mut t0 = 0.0_f64;
        let mut t1 = f64::INFINITY;
        for (o, d, lo, hi) in
            [(self.origin.x, self.dir.x, min.x, max.x), (self.origin.y, self.dir.y, min.y, max.y)]
        {
            if d == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
            } else {
                let (a, b) = ((lo - o) / d, (hi - o) / d);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
                if t0 > t1 {
                    return None;
                }
            }
        }
        Some(t0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    const EPS: f64 = 1e-12;

    #[test]
    fn wrap_angle_range() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < EPS);
        assert!((wrap_angle(-3.0 * PI) - PI).abs() < EPS);
        assert!((wrap_angle(-FRAC_PI_2) + FRAC_PI_2).abs() < EPS);
        assert!((wrap_angle(2.0 * PI + 0.25) - 0.25).abs() < EPS);
    }

    #[test]
    fn compose_mounts_a_sensor() {
        let base = Pose::new(1.0, 2.0, FRAC_PI_2);
        let s = base.compose(&Pose::new(0.3, 0.0, 0.0));
        assert!((s.x - 1.0).abs() < EPS && (s.y - 2.3).abs() < EPS);
        assert!((s.theta - FRAC_PI_2).abs() < EPS);
    }

    #[test]
    fn integrate_arc_closes_the_circle() {
        // 1 m/s forward at 1 rad/s: a circle of radius 1 m, back home after 2π s.
        let mut p = Pose::default();
        let t = Twist::new(1.0, 0.0, 1.0);
        p.integrate(&t, PI / 2.0);
        assert!((p.x - 1.0).abs() < EPS && (p.y - 1.0).abs() < EPS, "{p:?}");
        for _ in 0..3 {
            p.integrate(&t, PI / 2.0);
        }
        assert!(p.x.abs() < 1e-9 && p.y.abs() < 1e-9 && p.theta.abs() < 1e-9, "{p:?}");
    }

    #[test]
    fn integrate_is_step_size_independent() {
        // The exponential map is exact: one long step equals many short ones.
        let t = Twist::new(0.4, -0.2, 0.7);
        let mut one = Pose::new(0.5, -1.0, 0.3);
        let mut many = one;
        one.integrate(&t, 2.0);
        for _ in 0..2000 {
            many.integrate(&t, 0.001);
        }
        assert!((one.x - many.x).abs() < 1e-9 && (one.y - many.y).abs() < 1e-9);
        assert!((one.theta - many.theta).abs() < 1e-9);
    }

    #[test]
    fn ray_circle() {
        let r = Ray::new(Vec2::new(0.0, 0.0), 0.0);
        assert_eq!(r.hit_circle(Vec2::new(2.0, 0.0), 0.5), Some(1.5));
        // Tangent at y = 0.5 touches at x = 2.
        let d = r.hit_circle(Vec2::new(2.0, 0.5), 0.5).unwrap();
        assert!((d - 2.0).abs() < 1e-6);
        assert_eq!(r.hit_circle(Vec2::new(2.0, 0.6), 0.5), None);
        assert_eq!(r.hit_circle(Vec2::new(-2.0, 0.0), 0.5), None, "behind");
        assert_eq!(r.hit_circle(Vec2::new(0.1, 0.0), 0.5), Some(0.0), "inside");
    }

    #[test]
    fn ray_segment() {
        let r = Ray::new(Vec2::new(0.0, 0.0), 0.0);
        let d = r.hit_segment(Vec2::new(1.0, -1.0), Vec2::new(1.0, 1.0)).unwrap();
        assert!((d - 1.0).abs() < EPS);
        assert_eq!(r.hit_segment(Vec2::new(1.0, 0.1), Vec2::new(1.0, 1.0)), None);
        assert_eq!(r.hit_segment(Vec2::new(-1.0, -1.0), Vec2::new(-1.0, 1.0)), None);
        // Along the segment: the near end.
        let d = r.hit_segment(Vec2::new(3.0, 0.0), Vec2::new(2.0, 0.0)).unwrap();
        assert!((d - 2.0).abs() < EPS);
        // 45° onto a wall at x = 2.
        let r = Ray::new(Vec2::new(0.0, 0.0), PI / 4.0);
        let d = r.hit_segment(Vec2::new(2.0, -5.0), Vec2::new(2.0, 5.0)).unwrap();
        assert!((d - 2.0 * 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn ray_aabb() {
        let (lo, hi) = (Vec2::new(1.0, -0.5), Vec2::new(2.0, 0.5));
        let r = Ray::new(Vec2::new(0.0, 0.0), 0.0);
        assert_eq!(r.hit_aabb(lo, hi), Some(1.0));
        assert_eq!(Ray::new(Vec2::new(0.0, 0.0), PI).hit_aabb(lo, hi), None);
        assert_eq!(Ray::new(Vec2::new(1.5, 0.0), 0.3).hit_aabb(lo, hi), Some(0.0));
        // From below at 90°: enters the bottom face.
        let r = Ray::new(Vec2::new(1.5, -2.0), FRAC_PI_2);
        assert!((r.hit_aabb(lo, hi).unwrap() - 1.5).abs() < 1e-12);
        // Axis-parallel ray outside the slab.
        assert_eq!(Ray::new(Vec2::new(0.0, 1.0), 0.0).hit_aabb(lo, hi), None);
    }
}
