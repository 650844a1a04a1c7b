//! The air pressure a barometer on the base measures (issue 21): the International Standard
//! Atmosphere's troposphere at the robot's altitude, the day's weather as a sea-level pressure,
//! and the sensor's offset and noise.
//!
//! **Pressure vs altitude** (ISA, ISO 2533:1975; the troposphere below 11 km): with sea-level
//! pressure p₀, temperature T₀ = 288.15 K, lapse rate L = 0.0065 K/m, g = 9.806 65 m/s²,
//! molar mass of dry air M = 0.028 964 4 kg/mol and R = 8.314 462 618 J/(mol·K),
//!
//! ```text
//! p(h) = p₀ · (1 − L·h / T₀)^(g·M / (R·L))        (the exponent is 5.2559)
//! ```
//!
//! so near sea level 1 m of height is 12.0 Pa, and 1 Pa is 8.3 cm. The day's weather moves
//! p₀ (the standard 101 325 Pa is a default); the world's floor is flat, so the base's
//! altitude is the site's plus the sensor's height.
//!
//! **Sensor errors**: a per-device offset (absolute accuracy) drawn once within its bound, and
//! white Gaussian noise per sample. The IMU board's part is the LPS22HH: its datasheet
//! (DocID030890 Rev 2, the features on its first page) gives an absolute accuracy of 0.5 hPa
//! (±50 Pa) and a pressure noise of 0.65 Pa RMS; under which conditions of its Table 2 (the
//! low-noise mode, the low-pass filter) is NOT VERIFIED here, and the firmware runs it in
//! low-noise mode without the filter, so the real part may be noisier. The LPS22DF the board was
//! drawn for (kept for a board built with one), from its datasheet (DS13316 Rev 3, Table 2):
//! absolute accuracy ±0.2 hPa (±20 Pa) over 660–1260 hPa and −20…+65 °C (±0.45 hPa over its
//! whole range), RMS noise 0.0034 hPa (0.34 Pa) "with embedded filter" (its note 3: AVG = 512,
//! bandwidth ODR/9; the firmware averages 32 without the filter); the ±0.15 hPa soldering drift
//! is not added (it is part of what a board's offset is). Not modelled: temperature drift, the
//! airflow of a moving base, weather changing during a run, the board's heat around the port.

use crate::noise::Noise;

/// Standard sea-level pressure, Pa.
pub const P0_PA: f64 = 101_325.0;
const T0_K: f64 = 288.15;
const LAPSE_K_PER_M: f64 = 0.0065;
const G: f64 = 9.806_65;
const M_AIR: f64 = 0.028_964_4;
const R_GAS: f64 = 8.314_462_618;

/// ISA exponent g·M/(R·L).
fn exponent() -> f64 {
    G * M_AIR / (R_GAS * LAPSE_K_PER_M)
}

/// Static pressure at altitude `altitude_m` with sea-level pressure `sea_level_pa`, Pa.
pub fn isa_pressure(altitude_m: f64, sea_level_pa: f64) -> f64 {
    sea_level_pa * (1.0 - LAPSE_K_PER_M * altitude_m / T0_K).powf(exponent())
}

/// The altitude at which the ISA gives pressure `pressure_pa`, m (the inverse of
/// [`isa_pressure`]): what a barometric altimeter computes.
pub fn isa_altitude(pressure_pa: f64, sea_level_pa: f64) -> f64 {
    T0_K / LAPSE_K_PER_M * (1.0 - (pressure_pa / sea_level_pa).powf(1.0 / exponent()))
}

/// A barometer's error figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaroParams {
    /// Bound of the per-device offset, Pa.
    pub offset_pa: f64,
    /// White noise σ per sample, Pa.
    pub noise_pa: f64,
    /// Die temperature, °C.
    pub temperature_c: f64,
}

impl BaroParams {
    /// ST LPS22HH, the IMU board's (DocID030890 Rev 2, first page: see the module's doc).
    pub const LPS22HH: BaroParams =
        BaroParams { offset_pa: 50.0, noise_pa: 0.65, temperature_c: 30.0 };
    /// ST LPS22DF (DS13316 Rev 3, Table 2: see the module's doc).
    pub const LPS22DF: BaroParams =
        BaroParams { offset_pa: 20.0, noise_pa: 0.34, temperature_c: 30.0 };
    /// An ideal sensor.
    pub const IDEAL: BaroParams = BaroParams { offset_pa: 0.0, noise_pa: 0.0, temperature_c: 25.0 };
}

/// One sample as the sensor's outputs carry it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BaroSample {
    /// Static pressure at the port, Pa.
    pub pressure_pa: f64,
    /// Die temperature, °C.
    pub temperature_c: f64,
}

/// A barometer on the base, with its own offset and noise stream.
#[derive(Clone, Debug)]
pub struct Barometer {
    /// Its error figures.
    pub params: BaroParams,
    /// Sea-level pressure today, Pa.
    pub sea_level_pa: f64,
    offset_pa: f64,
    noise: Noise,
}

impl Barometer {
    /// A device whose offset is drawn from stream `stream` of `seed` (its noise from the next
    /// stream), so the same seed gives the same device, under a sea-level pressure of
    /// `sea_level_pa`.
    pub fn new(params: BaroParams, sea_level_pa: f64, seed: u64, stream: u64) -> Self {
        let mut d = Noise::new(seed, stream);
        let offset_pa = (2.0 * d.uniform() - 1.0) * params.offset_pa;
        Self { params, sea_level_pa, offset_pa, noise: Noise::new(seed, stream + 1) }
    }

    /// This device's offset, Pa.
    pub fn offset_pa(&self) -> f64 {
        self.offset_pa
    }

    /// What it reads without noise at altitude `altitude_m`, Pa.
    pub fn expected(&self, altitude_m: f64) -> f64 {
        isa_pressure(altitude_m, self.sea_level_pa) + self.offset_pa
    }

    /// One sample at altitude `altitude_m`, Pa.
    pub fn measure(&mut self, altitude_m: f64) -> f64 {
        self.expected(altitude_m) + self.noise.gaussian(self.params.noise_pa)
    }

    /// One sample at altitude `altitude_m`, with the die's temperature.
    pub fn sample(&mut self, altitude_m: f64) -> BaroSample {
        BaroSample {
            pressure_pa: self.measure(altitude_m),
            temperature_c: self.params.temperature_c,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_standard_atmosphere_at_known_heights() {
        assert_eq!(isa_pressure(0.0, P0_PA), P0_PA);
        // ISA tables: 1000 m 89 874.6 Pa, 5000 m 54 019.9 Pa, 11 000 m 22 632 Pa.
        for (h, p) in [(1000.0, 89_874.6), (5000.0, 54_019.9), (11_000.0, 22_632.1)] {
            assert!((isa_pressure(h, P0_PA) - p).abs() < 1.0, "{h} m: {}", isa_pressure(h, P0_PA));
        }
        // About 12 Pa per metre near sea level.
        let per_m = isa_pressure(0.0, P0_PA) - isa_pressure(1.0, P0_PA);
        assert!((per_m - 12.01).abs() < 0.01, "{per_m}");
    }

    #[test]
    fn the_altimeter_inverts_the_atmosphere() {
        for h in [-100.0, 0.0, 122.0, 1500.0, 8000.0] {
            for p0 in [98_000.0, P0_PA, 103_500.0] {
                let back = isa_altitude(isa_pressure(h, p0), p0);
                assert!((back - h).abs() < 1e-6, "{h} m at {p0} Pa: {back}");
            }
        }
    }

    #[test]
    fn a_device_reads_the_atmosphere_plus_its_offset() {
        let b = Barometer::new(BaroParams::LPS22HH, 100_000.0, 4, 3);
        for h in [0.0, 122.0, 900.0] {
            assert_eq!(b.expected(h), isa_pressure(h, 100_000.0) + b.offset_pa());
        }
        let ideal = Barometer::new(BaroParams::IDEAL, P0_PA, 4, 3);
        // 101 325 · (1 − 0.0065 · 122 / 288.15)^5.25588 = 99 868.0 Pa.
        assert!((ideal.expected(122.0) - 99_868.0).abs() < 0.1, "{}", ideal.expected(122.0));
    }

    #[test]
    fn a_device_has_its_offset_within_bound_and_its_noise() {
        for params in [BaroParams::LPS22HH, BaroParams::LPS22DF] {
            let mk = |seed| Barometer::new(params, P0_PA, seed, 3);
            let (mut a, b) = (mk(1), mk(1));
            assert_eq!(a.offset_pa(), b.offset_pa());
            assert_ne!(a.offset_pa(), mk(2).offset_pa());
            assert!(a.offset_pa().abs() <= params.offset_pa);
            let mean = a.expected(122.0);
            let xs: Vec<f64> = (0..4000).map(|_| a.measure(122.0)).collect();
            let m = xs.iter().sum::<f64>() / xs.len() as f64;
            let sd = (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
            // 5 standard errors of the mean; the sample σ of 4000 within 5 % (its own standard
            // error is σ/√8000, 1.1 %).
            let sem = params.noise_pa / 4000f64.sqrt();
            assert!((m - mean).abs() < 5.0 * sem, "{params:?}: mean {m}");
            assert!((sd / params.noise_pa - 1.0).abs() < 0.05, "{params:?}: sd {sd}");
        }
    }
}
