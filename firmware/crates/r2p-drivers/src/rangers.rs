//! Analog rangers: the datasheet transfer curves of the Sharp GP2Y0A21YK0F and GP2Y0A02YK0F
//! infrared rangers and the MaxBotix LV-MaxSonar-EZ sonar (output voltage against distance to
//! a target), as tables with linear interpolation, and their inverse.
//!
//! An analog ranger's driver is its curve. One copy serves both sides of the emulation: the
//! proximity firmware turns a voltage into a distance with it, the world model
//! (`firmware/host/world`) turns a distance into the voltage an emulated board reads. Adding a
//! sensor: a [`Curve`] here (its table and calibrated range, with the datasheet figure it
//! comes from), then its number in the proximity app's `curves::curve` and its name in the
//! world's `RangerKind`.
//!
//! Sources (typical curves, white target of 90 % reflectance, read off the datasheet figures to
//! about ±0.05 V, anchored on the datasheets' typical output specifications):
//! - Sharp GP2Y0A21YK0F datasheet, figure "distance measuring characteristics (output)",
//!   10–80 cm: 0.4 V typ at 80 cm, ΔV 1.9 V typ from 80 to 10 cm. The output peaks near 6 cm
//!   and falls towards 0 cm, so a target nearer than ~3 cm reads like one in range (the
//!   sensor's own ambiguity).
//! - Sharp GP2Y0A02YK0F datasheet, same figure, 20–150 cm: ~0.44 V at 150 cm, ΔV ~2.05 V
//!   from 150 to 20 cm; peak near 15 cm.
//! - MaxBotix LV-MaxSonar-EZ (EZ0–EZ4) datasheet, analog output: Vcc/512 per inch, 6–254 in;
//!   targets nearer than 6 in read as 6 in, nothing in view reads 254 in (so the last half
//!   inch at each end counts as out of range here).
//!
//! Error of the tables against the datasheets' typical curves: about ±0.05 V on the Sharps
//! (±3 % of distance near the range's middle, up to ±10 % at its far end where the curve is
//! flat), one inch (the sensor's resolution) on the MaxSonar. Unit-to-unit spread
//! (datasheet: ±0.15 V at the far end) is larger: calibrate per sensor if it matters.

/// The supply every curve here assumes, V (the rangers' datasheet condition, and what the
/// proximity board switches to its sensor connectors).
pub const SUPPLY_V: f32 = 5.0;

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

/// What a voltage within or outside a curve's calibrated range means.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// A target at this distance, m.
    Distance(f32),
    /// Nearer than the calibrated range.
    TooNear,
    /// Farther than the calibrated range, or nothing in view.
    TooFar,
}

/// Below this a channel has no sensor (or an unpowered one): the pull-down holds it at 0 V,
/// and every supported sensor drives more when powered (the MaxSonar's lowest output, 6 in at
/// 5 V, is 58.6 mV; the Sharps stay above 0.2 V).
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

/// Half an inch at each end of the MaxSonar's scale is out of range: it reads 6 in for
/// anything nearer and 254 in with nothing in view, so those readings are not distances.
pub const MAXSONAR_END_MARGIN_INCHES: f32 = 0.5;

const fn maxsonar_point(inches: f32) -> (f32, f32) {
    (inches * M_PER_INCH, SUPPLY_V * MAXSONAR_V_PER_INCH_PER_VCC * inches)
}

/// MaxBotix LV-MaxSonar-EZ analog output at 5 V supply (linear: Vcc/512 per inch). The line
/// has extra points half an inch inside each end, where the calibrated range stops.
pub const MAXSONAR_LV_EZ_5V: Curve = Curve {
    name: "LV-MaxSonar-EZ",
    points: &[
        maxsonar_point(MAXSONAR_MIN_INCHES),
        maxsonar_point(MAXSONAR_MIN_INCHES + MAXSONAR_END_MARGIN_INCHES),
        maxsonar_point(MAXSONAR_MAX_INCHES - MAXSONAR_END_MARGIN_INCHES),
        maxsonar_point(MAXSONAR_MAX_INCHES),
    ],
    min_range_m: (MAXSONAR_MIN_INCHES + MAXSONAR_END_MARGIN_INCHES) * M_PER_INCH,
    max_range_m: (MAXSONAR_MAX_INCHES - MAXSONAR_END_MARGIN_INCHES) * M_PER_INCH,
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
        for w in p.windows(2) {
            if distance_m <= w[1].0 {
                return lerp(distance_m, w[0], w[1]);
            }
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
        self.points.windows(2).find_map(|w| {
            let (a, b) = (w[0], w[1]);
            let inside = a.0 >= self.min_range_m && b.0 <= self.max_range_m;
            let (lo, hi) = if a.1 <= b.1 { (a.1, b.1) } else { (b.1, a.1) };
            (inside && volts >= lo && volts <= hi && a.1 != b.1)
                .then(|| lerp(volts, (a.1, a.0), (b.1, b.0)))
        })
    }

    /// What `volts` from this sensor means. A missing sensor (a channel pulled down below
    /// [`NO_SENSOR_BELOW_V`]) is the caller's business: it takes more than one sample to tell.
    pub fn classify(&self, volts: f32) -> Reading {
        if let Some(d) = self.distance_at(volts) {
            return Reading::Distance(d);
        }
        let (v_near, v_far) = self.range_volts();
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

    const ALL: [Curve; 3] = [GP2Y0A21YK, GP2Y0A02YK, MAXSONAR_LV_EZ_5V];

    #[test]
    fn tables_are_monotonic_over_their_range_and_above_the_no_sensor_level() {
        for c in ALL {
            assert!(c.points.windows(2).all(|w| w[0].0 < w[1].0), "{}: distances ascend", c.name);
            let cal: std::vec::Vec<_> =
                c.points.iter().filter(|p| p.0 >= c.min_range_m && p.0 <= c.max_range_m).collect();
            assert!(
                cal.first().unwrap().0 == c.min_range_m && cal.last().unwrap().0 == c.max_range_m
            );
            let dec = cal.windows(2).all(|w| w[1].1 < w[0].1);
            let inc = cal.windows(2).all(|w| w[1].1 > w[0].1);
            assert!(dec || inc, "{}: calibrated range must be monotonic", c.name);
            assert!(c.points.iter().all(|p| p.1 > NO_SENSOR_BELOW_V), "{}", c.name);
        }
    }

    #[test]
    fn datasheet_anchor_points() {
        assert_eq!(GP2Y0A21YK.volts_at(0.80), 0.40);
        assert!((GP2Y0A21YK.volts_at(0.10) - GP2Y0A21YK.volts_at(0.80) - 1.9).abs() < 0.01);
        assert!((GP2Y0A02YK.volts_at(0.20) - GP2Y0A02YK.volts_at(1.50) - 2.05).abs() < 0.02);
        let v = MAXSONAR_LV_EZ_5V.volts_at(100.0 * M_PER_INCH);
        assert!((v - 0.976_562_5).abs() < 1e-5, "9.766 mV per inch at 5 V: {v}");
    }

    #[test]
    fn inversion_round_trips_across_each_range() {
        for c in ALL {
            for i in 0..=100 {
                let d = c.min_range_m + (c.max_range_m - c.min_range_m) * i as f32 / 100.0;
                let back = c.distance_at(c.volts_at(d)).unwrap();
                assert!((back - d).abs() < 2e-5, "{} {d} -> {back}", c.name);
            }
        }
    }

    #[test]
    fn out_of_range_is_classified_not_extrapolated() {
        assert_eq!(GP2Y0A21YK.classify(3.0), Reading::TooNear);
        assert_eq!(GP2Y0A21YK.classify(0.30), Reading::TooFar);
        assert_eq!(GP2Y0A02YK.classify(2.70), Reading::TooNear);
        assert_eq!(MAXSONAR_LV_EZ_5V.classify(2.6), Reading::TooFar);
        assert_eq!(MAXSONAR_LV_EZ_5V.classify(0.05), Reading::TooNear);
        // The sensor's floor and ceiling readings are out of range, not distances.
        let inch = |i: f32| MAXSONAR_LV_EZ_5V.volts_at(i * M_PER_INCH);
        assert_eq!(MAXSONAR_LV_EZ_5V.classify(inch(6.0)), Reading::TooNear);
        assert_eq!(MAXSONAR_LV_EZ_5V.classify(inch(254.0)), Reading::TooFar);
        assert!(matches!(MAXSONAR_LV_EZ_5V.classify(inch(7.0)), Reading::Distance(_)));
        assert_eq!(GP2Y0A21YK.classify(1.30), Reading::Distance(0.20));
    }

    #[test]
    fn sharp_is_ambiguous_below_min_range() {
        // The peak lies below min range: 3 cm reads like ~12 cm (the real sensor's trap).
        let c = GP2Y0A21YK;
        assert!(c.volts_at(0.06) > c.volts_at(c.min_range_m));
        let d = c.distance_at(c.volts_at(0.03)).unwrap();
        assert!((d - 0.12).abs() < 1e-6, "{d}");
    }

    proptest::proptest! {
        /// Inverting the curve gives back the distance anywhere in the calibrated range.
        #[test]
        fn inversion_round_trip(which in 0usize..3, f in 0.0f32..=1.0) {
            let c = ALL[which];
            let d = c.min_range_m + f * (c.max_range_m - c.min_range_m);
            let back = c.distance_at(c.volts_at(d)).unwrap();
            // f32 rounding: a few ulp of the voltage (≤ 1e-6 V) over the flattest calibrated
            // slope (0.3 V/m, GP2Y0A02 at 1.5 m) is ≤ 4e-6 m, plus an ulp of d (≤ 5e-7 m).
            proptest::prop_assert!((back - d).abs() < 2e-5, "{} {d} -> {back}", c.name);
        }
    }
}
