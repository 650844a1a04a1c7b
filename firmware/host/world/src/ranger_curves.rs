//! Datasheet transfer curves of the rangers the proximity module reads: output voltage against
//! distance to a target, as tables with linear interpolation, and their inverse.
//!
//! This file is shared by the world model (which turns a distance into a voltage) and, later,
//! by the proximity firmware (which turns a voltage back into a distance), so that both use
//! the same curve. It must stay `no_std`: `core` only, no allocation, no float functions that
//! need `std` (a test compiles it as a `#![no_std]` crate). Values are `f32`, the firmware's
//! float.
//!
//! Sources (typical curves, white target of 90 % reflectance, read off the datasheet figures to
//! about ±0.05 V):
//! - Sharp GP2Y0A21YK0F, "distance measuring characteristics (output)", 10–80 cm; the output
//!   peaks near 6 cm and falls again towards 0 cm, so a target nearer than ~3 cm reads like
//!   one in range (an ambiguity of the sensor itself, kept here).
//! - Sharp GP2Y0A02YK0F, same figure, 20–150 cm; peak near 15 cm.
//! - MaxBotix LV-MaxSonar-EZ (EZ0–EZ4) analog output: Vcc/512 per inch, 6–254 in; targets
//!   nearer than 6 in read as 6 in.

/// A sensor's output voltage against target distance, with its calibrated (monotonic) range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Curve {
    /// Sensor name as in its datasheet.
    pub name: &'static str,
    /// (distance m, output V), distance strictly increasing; may start below `min_range_m`.
    pub points: &'static [(f32, f32)],
    /// Nearest distance of the calibrated range, m.
    pub min_range_m: f32,
    /// Farthest distance of the calibrated range, m.
    pub max_range_m: f32,
}

/// What a voltage read on a proximity channel means.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// A target at this distance, m.
    Distance(f32),
    /// Nearer than the calibrated range.
    TooNear,
    /// Farther than the calibrated range, or nothing in view.
    TooFar,
    /// No sensor: the channel's pull-down holds it near 0 V.
    NoSensor,
}

/// Below this a channel has no sensor (or an unpowered one): the proximity board pulls each
/// input to 0 V through 100 kΩ, and every modelled sensor drives more when powered (the
/// MaxSonar's lowest output, 6 in at 5 V, is 58.6 mV; the Sharps stay above 0.2 V).
pub const NO_SENSOR_BELOW_V: f32 = 0.030;

/// Sharp GP2Y0A21YK0F (10–80 cm) at 5 V supply.
pub const GP2Y0A21YK: Curve = Curve {
    name: "GP2Y0A21YK0F",
    points: &[
        (0.00, 0.30),
        (0.01, 0.75),
        (0.02, 1.40),
        (0.03, 2.00),
        (0.04, 2.50),
        (0.05, 2.85),
        (0.06, 3.12),
        (0.07, 3.05),
        (0.08, 2.80),
        (0.09, 2.53),
        (0.10, 2.30),
        (0.12, 2.00),
        (0.15, 1.65),
        (0.20, 1.30),
        (0.25, 1.08),
        (0.30, 0.92),
        (0.35, 0.80),
        (0.40, 0.74),
        (0.45, 0.66),
        (0.50, 0.60),
        (0.55, 0.55),
        (0.60, 0.50),
        (0.65, 0.47),
        (0.70, 0.45),
        (0.75, 0.42),
        (0.80, 0.40),
    ],
    min_range_m: 0.10,
    max_range_m: 0.80,
};

/// Sharp GP2Y0A02YK0F (20–150 cm) at 5 V supply.
pub const GP2Y0A02YK: Curve = Curve {
    name: "GP2Y0A02YK0F",
    points: &[
        (0.00, 0.50),
        (0.05, 1.50),
        (0.10, 2.35),
        (0.15, 2.75),
        (0.20, 2.50),
        (0.25, 2.25),
        (0.30, 2.00),
        (0.35, 1.75),
        (0.40, 1.55),
        (0.50, 1.25),
        (0.60, 1.05),
        (0.70, 0.90),
        (0.80, 0.80),
        (0.90, 0.72),
        (1.00, 0.65),
        (1.10, 0.60),
        (1.20, 0.55),
        (1.30, 0.51),
        (1.40, 0.47),
        (1.50, 0.44),
    ],
    min_range_m: 0.20,
    max_range_m: 1.50,
};

/// Metres per inch.
pub const M_PER_INCH: f32 = 0.0254;
/// MaxBotix LV-MaxSonar-EZ analog scale: volts per inch per volt of supply (Vcc/512 per inch).
pub const MAXSONAR_V_PER_INCH_PER_VCC: f32 = 1.0 / 512.0;
/// Nearest reading of the LV-MaxSonar-EZ, inches (nearer targets read as this).
pub const MAXSONAR_MIN_INCHES: f32 = 6.0;
/// Farthest reading of the LV-MaxSonar-EZ, inches (also what it reads with nothing in view).
pub const MAXSONAR_MAX_INCHES: f32 = 254.0;

/// MaxBotix LV-MaxSonar-EZ analog output at 5 V supply (linear: Vcc/512 per inch).
pub const MAXSONAR_LV_EZ_5V: Curve = Curve {
    name: "LV-MaxSonar-EZ",
    points: &[
        (MAXSONAR_MIN_INCHES * M_PER_INCH, 5.0 * MAXSONAR_V_PER_INCH_PER_VCC * MAXSONAR_MIN_INCHES),
        (MAXSONAR_MAX_INCHES * M_PER_INCH, 5.0 * MAXSONAR_V_PER_INCH_PER_VCC * MAXSONAR_MAX_INCHES),
    ],
    min_range_m: MAXSONAR_MIN_INCHES * M_PER_INCH,
    max_range_m: MAXSONAR_MAX_INCHES * M_PER_INCH,
};

fn lerp(x: f32, (x0, y0): (f32, f32), (x1, y1): (f32, f32)) -> f32 {
    y0 + (y1 - y0) * (x - x0) / (x1 - x0)
}

impl Curve {
    /// Output voltage for a target at `distance_m`, interpolated; the end values outside the
    /// table.
    pub fn volts_at(&self, distance_m: f32) -> f32 {
        let p = self.points;
        if distance_m <= p[0].0 {
            return p[0].1;
        }
        let mut i = 1;
        while i < p.len() {
            if distance_m <= p[i].0 {
                return lerp(distance_m, p[i - 1], p[i]);
            }
            i += 1;
        }
        p[p.len() - 1].1
    }

    /// Voltages at the two ends of the calibrated range: (at min range, at max range).
    pub fn range_volts(&self) -> (f32, f32) {
        (self.volts_at(self.min_range_m), self.volts_at(self.max_range_m))
    }

    /// The distance whose output is `volts`, within the calibrated range only (where the
    /// curve is monotonic); `None` outside it.
    pub fn distance_at(&self, volts: f32) -> Option<f32> {
        let p = self.points;
        let mut i = 1;
        while i < p.len() {
            let (a, b) = (p[i - 1], p[i]);
            if a.0 >= self.min_range_m && b.0 <= self.max_range_m {
                let (lo, hi) = if a.1 <= b.1 { (a.1, b.1) } else { (b.1, a.1) };
                if volts >= lo && volts <= hi && a.1 != b.1 {
                    let (sa, sb) = ((a.1, a.0), (b.1, b.0));
                    return Some(lerp(volts, sa, sb));
                }
            }
            i += 1;
        }
        None
    }

    /// What `volts` on a channel wired to this sensor means (see [`Reading`]).
    pub fn classify(&self, volts: f32) -> Reading {
        if volts < NO_SENSOR_BELOW_V {
            return Reading::NoSensor;
        }
        if let Some(d) = self.distance_at(volts) {
            return Reading::Distance(d);
        }
        let (v_near, v_far) = self.range_volts();
        // Outside the calibrated span: on the near side or the far side of it.
        let nearer = if v_near > v_far { volts > v_near } else { volts < v_near };
        if nearer {
            Reading::TooNear
        } else {
            Reading::TooFar
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const ALL: [Curve; 3] = [GP2Y0A21YK, GP2Y0A02YK, MAXSONAR_LV_EZ_5V];

    #[test]
    fn tables_are_well_formed() {
        for c in ALL {
            assert!(c.points.windows(2).all(|w| w[0].0 < w[1].0), "{}: distances ascend", c.name);
            // The calibrated range ends on table points and is strictly monotonic.
            assert!(c.points.iter().any(|p| p.0 == c.min_range_m), "{}", c.name);
            assert!(c.points.iter().any(|p| p.0 == c.max_range_m), "{}", c.name);
            let cal: Vec<_> =
                c.points.iter().filter(|p| p.0 >= c.min_range_m && p.0 <= c.max_range_m).collect();
            let dec = cal.windows(2).all(|w| w[1].1 < w[0].1);
            let inc = cal.windows(2).all(|w| w[1].1 > w[0].1);
            assert!(dec || inc, "{}: calibrated range must be monotonic", c.name);
            // Every powered output is distinguishable from an empty (pulled-down) channel.
            assert!(c.points.iter().all(|p| p.1 > NO_SENSOR_BELOW_V), "{}", c.name);
        }
    }

    #[test]
    fn datasheet_anchor_points() {
        // GP2Y0A21: 0.4 V typ at 80 cm, 1.9 V typ difference from 80 to 10 cm.
        assert_eq!(GP2Y0A21YK.volts_at(0.80), 0.40);
        assert!((GP2Y0A21YK.volts_at(0.10) - GP2Y0A21YK.volts_at(0.80) - 1.9).abs() < 0.01);
        // GP2Y0A02: 0.4–0.45 V at 150 cm, ~2.05 V difference from 150 to 20 cm.
        assert!((GP2Y0A02YK.volts_at(0.20) - GP2Y0A02YK.volts_at(1.50) - 2.05).abs() < 0.02);
        // MaxSonar at 5 V: 9.766 mV per inch; 100 in → 0.9766 V.
        let v = MAXSONAR_LV_EZ_5V.volts_at(100.0 * M_PER_INCH);
        assert!((v - 0.9765625).abs() < 1e-5, "{v}");
    }

    #[test]
    fn sharp_is_ambiguous_below_min_range() {
        // The peak lies below min range: 3 cm reads like ~12 cm (the real sensor's trap).
        let c = GP2Y0A21YK;
        assert!(c.volts_at(0.06) > c.volts_at(c.min_range_m));
        let v3 = c.volts_at(0.03);
        let d = c.distance_at(v3).unwrap();
        assert!((d - 0.12).abs() < 1e-6, "{d}");
        // A voltage above the range's near end is reported as too near, not as a distance.
        assert_eq!(c.classify(3.0), Reading::TooNear);
    }

    #[test]
    fn classify_out_of_range_and_no_sensor() {
        assert_eq!(GP2Y0A21YK.classify(0.0008), Reading::NoSensor);
        assert_eq!(GP2Y0A21YK.classify(0.30), Reading::TooFar);
        assert_eq!(GP2Y0A02YK.classify(2.70), Reading::TooNear);
        assert_eq!(MAXSONAR_LV_EZ_5V.classify(2.6), Reading::TooFar);
        assert_eq!(MAXSONAR_LV_EZ_5V.classify(0.0), Reading::NoSensor);
        match GP2Y0A21YK.classify(1.30) {
            Reading::Distance(d) => assert!((d - 0.20).abs() < 1e-6),
            r => panic!("{r:?}"),
        }
    }

    proptest! {
        /// Inverting the curve gives back the distance anywhere in the calibrated range.
        #[test]
        fn inversion_round_trip(which in 0usize..3, f in 0.0f32..=1.0) {
            let c = ALL[which];
            let d = c.min_range_m + f * (c.max_range_m - c.min_range_m);
            let back = c.distance_at(c.volts_at(d)).unwrap();
            // f32 rounding: a few ulp of the voltage (≤ 1e-6 V) over the flattest calibrated
            // slope (0.3 V/m, GP2Y0A02 at 1.5 m) is ≤ 4e-6 m, plus an ulp of d (≤ 5e-7 m).
            prop_assert!((back - d).abs() < 2e-5, "{} {d} -> {back}", c.name);
        }
    }
}
