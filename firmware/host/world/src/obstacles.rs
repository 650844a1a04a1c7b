//! The 2-D world's obstacles and what a ranger's beam sees of them.
//!
//! Obstacles are static circles, walls (segments) and axis-aligned boxes. The robot itself is
//! not an obstacle, and nothing stops the base from driving through one (collisions are not
//! modelled: a test that cares checks distances).

use crate::geometry::{Ray, Vec2};

/// One static obstacle.
#[derive(Clone, Debug, PartialEq)]
pub enum Obstacle {
    /// A round post.
    Circle {
        /// Centre.
        center: Vec2,
        /// Radius, m.
        radius: f64,
    },
    /// A wall of no thickness from `a` to `b`.
    Wall {
        /// One end.
        a: Vec2,
        /// The other end.
        b: Vec2,
    },
    /// An axis-aligned box.
    Box {
        /// Lower-left corner.
        min: Vec2,
        /// Upper-right corner.
        max: Vec2,
    },
}

impl Obstacle {
    /// Distance along `ray` to this obstacle, if the ray hits it.
    pub fn hit(&self, ray: &Ray) -> Option<f64> {
        match *self {
            Obstacle::Circle { center, radius } => ray.hit_circle(center, radius),
            Obstacle::Wall { a, b } => ray.hit_segment(a, b),
            Obstacle::Box { min, max } => ray.hit_aabb(min, max),
        }
    }
}

/// A beam: the cone a ranger sees, `half_angle` either side of its axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beam {
    /// Half the cone's opening angle, rad (0 for a single ray).
    pub half_angle: f64,
    /// Farthest distance the sensor can see, m.
    pub max_range: f64,
}

/// Angular spacing of the rays sampling a beam: 0.5°, so that across a 1 m range the gap
/// between rays is under 9 mm (a 1 cm post is never missed inside the cone).
pub const BEAM_RAY_SPACING: f64 = 0.5 * std::f64::consts::PI / 180.0;

/// All the obstacles of a world.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Obstacles {
    items: Vec<Obstacle>,
}

impl Obstacles {
    /// A world holding `items`.
    pub fn new(items: Vec<Obstacle>) -> Self {
        Self { items }
    }

    /// The obstacles, in the order given.
    pub fn items(&self) -> &[Obstacle] {
        &self.items
    }

    /// Nearest hit along `ray` no farther than `max_range`.
    pub fn cast(&self, ray: &Ray, max_range: f64) -> Option<f64> {
        self.items.iter().filter_map(|o| o.hit(ray)).filter(|&d| d <= max_range).reduce(f64::min)
    }

    /// Nearest hit within `beam` from `origin` along the axis `angle` (world frame): a sonar's
    /// first echo comes from the nearest surface anywhere in its cone. The cone is sampled by
    /// rays every [`BEAM_RAY_SPACING`] or finer (always including the axis and both edges).
    pub fn cast_beam(&self, origin: Vec2, angle: f64, beam: &Beam) -> Option<f64> {
        let n = (2.0 * beam.half_angle / BEAM_RAY_SPACING).ceil() as usize;
        // An even number of intervals puts a ray on the axis.
        let n = n + n % 2;
        (0..=n)
            .filter_map(|i| {
                // Offsets symmetric about the axis, exactly 0 in the middle.
                let k = 2.0 * i as f64 - n as f64;
                let a = if n == 0 { angle } else { angle + beam.half_angle * k / n as f64 };
                self.cast(&Ray::new(origin, a), beam.max_range)
            })
            .reduce(f64::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn room() -> Obstacles {
        Obstacles::new(vec![
            Obstacle::Wall { a: Vec2::new(-2.0, -2.0), b: Vec2::new(2.0, -2.0) },
            Obstacle::Wall { a: Vec2::new(2.0, -2.0), b: Vec2::new(2.0, 2.0) },
            Obstacle::Wall { a: Vec2::new(2.0, 2.0), b: Vec2::new(-2.0, 2.0) },
            Obstacle::Wall { a: Vec2::new(-2.0, 2.0), b: Vec2::new(-2.0, -2.0) },
            Obstacle::Circle { center: Vec2::new(1.0, 0.0), radius: 0.1 },
            Obstacle::Box { min: Vec2::new(-1.2, 0.8), max: Vec2::new(-0.8, 1.2) },
        ])
    }

    #[test]
    fn nearest_obstacle_wins() {
        let w = room();
        let d = w.cast(&Ray::new(Vec2::default(), 0.0), 10.0).unwrap();
        assert!((d - 0.9).abs() < 1e-12, "post before the east wall: {d}");
        let d = w.cast(&Ray::new(Vec2::default(), std::f64::consts::PI), 10.0).unwrap();
        assert!((d - 2.0).abs() < 1e-12, "west wall: {d}");
        assert_eq!(w.cast(&Ray::new(Vec2::default(), 0.0), 0.5), None, "beyond max range");
    }

    #[test]
    fn cone_sees_off_axis_obstacle_a_ray_misses() {
        // A post 1 m ahead, 0.2 m to the side (11.3° off axis).
        let w =
            Obstacles::new(vec![Obstacle::Circle { center: Vec2::new(1.0, 0.2), radius: 0.02 }]);
        let narrow = Beam { half_angle: 2f64.to_radians(), max_range: 3.0 };
        let cone = Beam { half_angle: 15f64.to_radians(), max_range: 3.0 };
        assert_eq!(w.cast_beam(Vec2::default(), 0.0, &narrow), None);
        let d = w.cast_beam(Vec2::default(), 0.0, &cone).unwrap();
        // Nearest surface point: centre distance minus radius, to within the ray spacing's
        // chord on the post (r(1 − cos(Δ/2·d/r)) ≪ 1 mm here).
        let exact = 1.0f64.hypot(0.2) - 0.02;
        assert!((d - exact).abs() < 1e-3, "{d} vs {exact}");
    }

    proptest! {
        /// A ray from inside a box of walls hits the wall the geometry says it hits.
        #[test]
        fn ray_hits_square_room_wall(x in -1.9f64..1.9, y in -1.9f64..1.9, a in -std::f64::consts::PI..std::f64::consts::PI) {
            let w = Obstacles::new(room().items()[..4].to_vec());
            let d = w.cast(&Ray::new(Vec2::new(x, y), a), 100.0).unwrap();
            let hit = Vec2::new(x, y) + Vec2::from_angle(a) * d;
            let on_wall = (hit.x.abs() - 2.0).abs() < 1e-9 || (hit.y.abs() - 2.0).abs() < 1e-9;
            prop_assert!(on_wall, "hit {hit:?}");
            prop_assert!(hit.x.abs() <= 2.0 + 1e-9 && hit.y.abs() <= 2.0 + 1e-9);
        }
    }
}
