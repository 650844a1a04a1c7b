//! Range sensors on the proximity module: what voltage each puts on its channel.
//!
//! A ranger measures once per cycle (Sharp: every 38.3 ms typ.; LV-MaxSonar-EZ: every 49 ms)
//! and holds its output between measurements, as the real parts do. A measurement finds the
//! nearest obstacle in its beam ([`Obstacles::cast_beam`]) and maps the distance through its
//! datasheet curve (`r2p_drivers::rangers`) plus Gaussian output noise:
//!
//! - Sharp, nearer than the calibrated range: the curve's non-monotonic part (the output
//!   peaks, then falls towards 0 cm). Farther than the table: the output keeps falling as the
//!   triangulation law 1/d from the last point, down to the no-target level, which is also what
//!   it reads with nothing in view.
//! - MaxSonar: 1-inch steps; nearer than 6 in reads 6 in, nothing within 254 in reads 254 in.
//! - Disconnected, or its 5 V switched off: the board's 100 kΩ pull-down holds the channel at
//!   0 V. After power comes back the output stays at 0 V until the first measurement ends.
//!
//! Beams are cones sampled by rays (see [`BEAM_RAY_SPACING`](crate::obstacles::BEAM_RAY_SPACING)):
//! a Sharp sees a narrow spot (±2°), a sonar the nearest surface in a ±15° cone (the EZ1's
//! beam for large targets, narrowing with range in reality: not modelled). Surface angle and
//! colour (Sharp) or acoustic reflectivity (sonar) are not modelled: every surface reflects
//! like the datasheet's white card.

use crate::geometry::Pose;
use crate::noise::Noise;
use crate::obstacles::{Beam, Obstacles};
use r2p_drivers::rangers::{self, Curve};

/// A kind of range sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RangerKind {
    /// Sharp GP2Y0A21YK0F, 10–80 cm infrared triangulation.
    Gp2y0a21,
    /// Sharp GP2Y0A02YK0F, 20–150 cm infrared triangulation.
    Gp2y0a02,
    /// MaxBotix LV-MaxSonar-EZ, 6–254 in ultrasonic, analog output.
    MaxSonarLvEz,
}

/// Supply of the sensors (the proximity board's switched 5 V, the curves' condition), V.
pub const SENSOR_SUPPLY_V: f64 = rangers::SUPPLY_V as f64;

impl RangerKind {
    /// Every kind, in robot-file order.
    pub const ALL: [RangerKind; 3] =
        [RangerKind::Gp2y0a21, RangerKind::Gp2y0a02, RangerKind::MaxSonarLvEz];

    /// The name the robot file uses.
    pub fn name(self) -> &'static str {
        match self {
            RangerKind::Gp2y0a21 => "gp2y0a21",
            RangerKind::Gp2y0a02 => "gp2y0a02",
            RangerKind::MaxSonarLvEz => "maxsonar-lv-ez",
        }
    }

    /// The kind called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Its datasheet curve (at 5 V supply).
    pub fn curve(self) -> &'static Curve {
        match self {
            RangerKind::Gp2y0a21 => &rangers::GP2Y0A21YK,
            RangerKind::Gp2y0a02 => &rangers::GP2Y0A02YK,
            RangerKind::MaxSonarLvEz => &rangers::MAXSONAR_LV_EZ_5V,
        }
    }

    /// Measurement period, s (Sharp datasheet 38.3 ms typ.; MaxSonar 49 ms).
    pub fn period_s(self) -> f64 {
        match self {
            RangerKind::Gp2y0a21 | RangerKind::Gp2y0a02 => 0.0383,
            RangerKind::MaxSonarLvEz => 0.049,
        }
    }

    /// Output noise per measurement, V rms (assumed: Sharp outputs wander by tens of mV;
    /// the MaxSonar's filtered-PWM output by a few).
    pub fn noise_v(self) -> f64 {
        match self {
            RangerKind::Gp2y0a21 | RangerKind::Gp2y0a02 => 0.010,
            RangerKind::MaxSonarLvEz => 0.002,
        }
    }

    /// Output with nothing in view (Sharp, assumed; MaxSonar: its 254 in maximum), V.
    pub fn no_target_v(self) -> f64 {
        match self {
            RangerKind::Gp2y0a21 => 0.25,
            RangerKind::Gp2y0a02 => 0.30,
            RangerKind::MaxSonarLvEz => inches_to_volts(rangers::MAXSONAR_MAX_INCHES.into()),
        }
    }

    /// The beam the sensor sees with. Sharp rays reach as far as the output still falls
    /// above the no-target level (d_last·V_last/V_none); the sonar's reach is 254 in.
    pub fn beam(self) -> Beam {
        let deg = std::f64::consts::PI / 180.0;
        match self {
            RangerKind::Gp2y0a21 | RangerKind::Gp2y0a02 => {
                let (d, v) = self.last_point();
                Beam { half_angle: 2.0 * deg, max_range: d * v / self.no_target_v() }
            }
            RangerKind::MaxSonarLvEz => Beam {
                half_angle: 15.0 * deg,
                max_range: f64::from(rangers::MAXSONAR_MAX_INCHES * rangers::M_PER_INCH),
            },
        }
    }

    /// Supply current, A (datasheets: 30 mA, 33 mA typ.; MaxSonar 2.0 mA at 5 V).
    pub fn supply_current_a(self) -> f64 {
        match self {
            RangerKind::Gp2y0a21 => 0.030,
            RangerKind::Gp2y0a02 => 0.033,
            RangerKind::MaxSonarLvEz => 0.002,
        }
    }

    fn last_point(self) -> (f64, f64) {
        let p = self.curve().points[self.curve().points.len() - 1];
        (p.0.into(), p.1.into())
    }

    /// Noise-free output for the nearest target at `distance` m (`None`: nothing in view).
    pub fn output_for(self, distance: Option<f64>) -> f64 {
        match self {
            RangerKind::MaxSonarLvEz => {
                let inches = distance.map_or(f64::INFINITY, |d| (d / 0.0254).round());
                let lo = f64::from(rangers::MAXSONAR_MIN_INCHES);
                let hi = f64::from(rangers::MAXSONAR_MAX_INCHES);
                inches_to_volts(inches.clamp(lo, hi))
            }
            _ => {
                let Some(d) = distance else { return self.no_target_v() };
                let (d_last, v_last) = self.last_point();
                if d <= d_last {
                    f64::from(self.curve().volts_at(d as f32))
                } else {
                    (v_last * d_last / d).max(self.no_target_v())
                }
            }
        }
    }
}

fn inches_to_volts(inches: f64) -> f64 {
    SENSOR_SUPPLY_V * f64::from(rangers::MAXSONAR_V_PER_INCH_PER_VCC) * inches
}

/// One ranger mounted on the robot's base.
#[derive(Clone, Debug, PartialEq)]
pub struct Ranger {
    /// Its kind.
    pub kind: RangerKind,
    /// Its pose in the base frame (the beam's axis along its +x).
    pub mount: Pose,
    connected: bool,
    powered: bool,
    /// Output held since the last measurement, V.
    held_v: f64,
    /// Time of the next measurement, s.
    next_s: f64,
    /// True distance at the last measurement (nearest in the beam), m.
    last_distance: Option<f64>,
}

impl Ranger {
    /// A powered, connected ranger whose first measurement ends at `first_s` (its phase).
    pub fn new(kind: RangerKind, mount: Pose, first_s: f64) -> Self {
        Self {
            kind,
            mount,
            connected: true,
            powered: true,
            held_v: 0.0,
            next_s: first_s,
            last_distance: None,
        }
    }

    /// Voltage on the board's channel now, V.
    pub fn output_v(&self) -> f64 {
        if self.connected && self.powered {
            self.held_v
        } else {
            0.0
        }
    }

    /// Nearest obstacle distance at the last measurement (the truth the output encodes).
    pub fn last_distance(&self) -> Option<f64> {
        self.last_distance
    }

    /// Whether the sensor's cable is connected.
    pub fn connected(&self) -> bool {
        self.connected
    }

    /// Connects or disconnects the sensor (fault injection).
    pub fn set_connected(&mut self, c: bool) {
        self.connected = c;
    }

    /// Switches the sensor's supply at time `now_s`; on power-up the output is 0 V until one
    /// full measurement has completed.
    pub fn set_powered(&mut self, on: bool, now_s: f64) {
        if on && !self.powered {
            self.held_v = 0.0;
            self.next_s = now_s + self.kind.period_s();
        }
        self.powered = on;
    }

    /// The distance the sensor would measure from base pose `base` (no noise, no hold).
    pub fn sense(&self, base: &Pose, obstacles: &Obstacles) -> Option<f64> {
        let p = base.compose(&self.mount);
        obstacles.cast_beam(p.position(), p.theta, &self.kind.beam())
    }

    /// Whether the sensor is powered.
    pub fn powered(&self) -> bool {
        self.powered
    }

    fn measure(&mut self, base: &Pose, obstacles: &Obstacles, noise: &mut Noise) {
        let d = self.sense(base, obstacles);
        self.last_distance = d;
        self.held_v = (self.kind.output_for(d) + noise.gaussian(self.kind.noise_v())).max(0.0);
    }

    /// Takes a measurement now without moving the schedule: a sensor that was already
    /// running when the world started.
    pub fn prime(&mut self, base: &Pose, obstacles: &Obstacles, noise: &mut Noise) {
        if self.powered {
            self.measure(base, obstacles, noise);
        }
    }

    /// Runs the measurements due by `now_s` with the base at `base`.
    pub fn update(&mut self, now_s: f64, base: &Pose, obstacles: &Obstacles, noise: &mut Noise) {
        if !self.powered {
            return;
        }
        if now_s >= self.next_s {
            self.measure(base, obstacles, noise);
            // Measurements missed by a long step are skipped, not replayed.
            let period = self.kind.period_s();
            self.next_s += period * ((now_s - self.next_s) / period).floor().max(0.0) + period;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vec2;
    use crate::obstacles::Obstacle;

    fn wall_at(x: f64) -> Obstacles {
        Obstacles::new(vec![Obstacle::Wall { a: Vec2::new(x, -5.0), b: Vec2::new(x, 5.0) }])
    }

    #[test]
    fn sharp_reads_its_curve_and_falls_off_beyond() {
        let k = RangerKind::Gp2y0a21;
        assert!((k.output_for(Some(0.30)) - 0.92).abs() < 1e-6);
        // Beyond 80 cm: 0.4 V·0.8 m/d, so 0.32 V at 1 m, floored at 0.25 V from 1.28 m.
        // (Table values are f32: compare to 1e-6.)
        assert!((k.output_for(Some(1.0)) - 0.32).abs() < 1e-6);
        assert!((k.beam().max_range - 1.28).abs() < 1e-6);
        assert_eq!(k.output_for(Some(1.4)), 0.25);
        assert_eq!(k.output_for(None), 0.25);
        // Too near: on the falling side of the peak.
        assert!(k.output_for(Some(0.02)) < k.output_for(Some(0.06)));
    }

    #[test]
    fn maxsonar_steps_and_clamps() {
        let k = RangerKind::MaxSonarLvEz;
        let per_inch = 5.0 / 512.0;
        assert!((k.output_for(Some(1.0)) - 39.0 * per_inch).abs() < 1e-12, "1 m → 39 in");
        assert!((k.output_for(Some(0.05)) - 6.0 * per_inch).abs() < 1e-12, "near → 6 in");
        assert!((k.output_for(None) - 254.0 * per_inch).abs() < 1e-12, "none → 254 in");
        assert!((k.output_for(Some(9.0)) - 254.0 * per_inch).abs() < 1e-12);
    }

    #[test]
    fn measurement_is_held_for_a_period() {
        let mut r = Ranger::new(RangerKind::Gp2y0a21, Pose::default(), 0.0);
        let mut n = Noise::new(0, 0);
        let base = Pose::default();
        r.update(0.0, &base, &wall_at(0.30), &mut n);
        let v = r.output_v();
        assert!((v - 0.92).abs() < 5.0 * 0.010, "{v}");
        // The wall moves; the output does not change until the next measurement at 38.3 ms.
        r.update(0.038, &base, &wall_at(0.50), &mut n);
        assert_eq!(r.output_v(), v);
        r.update(0.0384, &base, &wall_at(0.50), &mut n);
        assert!((r.output_v() - 0.60).abs() < 5.0 * 0.010, "{}", r.output_v());
        assert_eq!(r.last_distance(), Some(0.50));
    }

    #[test]
    fn mount_pose_and_base_pose_place_the_beam() {
        // Sensor 0.3 m left of centre facing left; base at (0, 0) facing +x: wall at y = 1.
        let wall = Obstacles::new(vec![Obstacle::Wall {
            a: Vec2::new(-5.0, 1.0),
            b: Vec2::new(5.0, 1.0),
        }]);
        let r = Ranger::new(
            RangerKind::Gp2y0a02,
            Pose::new(0.0, 0.3, std::f64::consts::FRAC_PI_2),
            0.0,
        );
        let d = r.sense(&Pose::default(), &wall).unwrap();
        assert!((d - 0.7).abs() < 1e-12, "{d}");
        // Turn the base 180°: the sensor faces −y from y = −0.3; a wall at y = 1 is behind.
        assert_eq!(r.sense(&Pose::new(0.0, 0.0, std::f64::consts::PI), &wall), None);
    }

    #[test]
    fn disconnected_or_unpowered_reads_zero() {
        let mut r = Ranger::new(RangerKind::Gp2y0a21, Pose::default(), 0.0);
        let mut n = Noise::new(0, 0);
        r.update(0.0, &Pose::default(), &wall_at(0.3), &mut n);
        assert!(r.output_v() > 0.5);
        r.set_connected(false);
        assert_eq!(r.output_v(), 0.0);
        r.set_connected(true);
        r.set_powered(false, 0.01);
        assert_eq!(r.output_v(), 0.0);
        r.set_powered(true, 0.02);
        r.update(0.05, &Pose::default(), &wall_at(0.3), &mut n);
        assert_eq!(r.output_v(), 0.0, "no output until a full cycle after power-up");
        r.update(0.059, &Pose::default(), &wall_at(0.3), &mut n);
        assert!(r.output_v() > 0.5);
    }
}
