//! Hall-effect current sensor (Allegro ACS711/ACS725 class): a voltage centred on Vcc/2.
//!
//! Model: Vout = Vcc/2 + S·(Vcc/Vref_sens)·I + noise, ratiometric to the supply as the
//! datasheet states (zero point and sensitivity scale with Vcc), linear up to the output's
//! saturation near the rails. Its 100 kHz bandwidth is far above anything the firmware samples
//! at, so successive reads get independent noise and no lag.

use crate::noise::Noise;

/// Parameters of one Hall current sensor part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HallSensorParams {
    /// Part name.
    pub part: &'static str,
    /// Sensitivity, V/A, at the supply `sensitivity_vcc`.
    pub sensitivity_v_per_a: f64,
    /// Supply at which `sensitivity_v_per_a` is specified, V.
    pub sensitivity_vcc: f64,
    /// Output noise, V rms.
    pub noise_v: f64,
    /// How close to each rail the output can swing, V.
    pub rail_margin_v: f64,
}

impl HallSensorParams {
    /// Allegro ACS725LLCTR-30AB-T (the motor board's U102): ±30 A, 44 mV/A at 3.3 V. Noise
    /// 6 mV rms (as the ACS711's: the datasheet's figure is not verified) and a 0.2 V swing
    /// margin from each rail (hardware/motor's calculation takes the output as 0.2–3.1 V).
    pub const ACS725_30AB: HallSensorParams = HallSensorParams {
        part: "ACS725LLCTR-30AB-T",
        sensitivity_v_per_a: 0.044,
        sensitivity_vcc: 3.3,
        noise_v: 0.006,
        rail_margin_v: 0.2,
    };
    /// Allegro ACS711KEXLT-15AB: ±15.5 A, 90 mV/A at 3.3 V (datasheet). Noise 6 mV rms and a
    /// 50 mV saturation margin are assumptions of the right order for this part.
    pub const ACS711_15AB: HallSensorParams = HallSensorParams {
        part: "ACS711KEXLT-15AB",
        sensitivity_v_per_a: 0.090,
        sensitivity_vcc: 3.3,
        noise_v: 0.006,
        rail_margin_v: 0.05,
    };
}

/// A Hall current sensor on a supply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HallCurrentSensor {
    /// The part.
    pub params: HallSensorParams,
    /// Its supply, V.
    pub vcc: f64,
}

impl HallCurrentSensor {
    /// Sensitivity at this supply, V/A.
    pub fn sensitivity(&self) -> f64 {
        self.params.sensitivity_v_per_a * self.vcc / self.params.sensitivity_vcc
    }

    /// Output for `amps` without noise.
    pub fn output_ideal(&self, amps: f64) -> f64 {
        let v = self.vcc / 2.0 + self.sensitivity() * amps;
        let m = self.params.rail_margin_v;
        v.clamp(m, self.vcc - m)
    }

    /// Output for `amps` with a noise draw from `noise`.
    pub fn output(&self, amps: f64, noise: &mut Noise) -> f64 {
        let v = self.vcc / 2.0 + self.sensitivity() * amps + noise.gaussian(self.params.noise_v);
        let m = self.params.rail_margin_v;
        v.clamp(m, self.vcc - m)
    }

    /// The current a noiseless output `volts` stands for (inside the linear range).
    pub fn amps(&self, volts: f64) -> f64 {
        (volts - self.vcc / 2.0) / self.sensitivity()
    }

    /// Largest current, either sign, that does not saturate the output.
    pub fn linear_range(&self) -> f64 {
        (self.vcc / 2.0 - self.params.rail_margin_v) / self.sensitivity()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: HallCurrentSensor =
        HallCurrentSensor { params: HallSensorParams::ACS711_15AB, vcc: 3.3 };

    #[test]
    fn zero_at_half_supply_and_datasheet_slope() {
        assert_eq!(S.output_ideal(0.0), 1.65);
        assert!((S.output_ideal(10.0) - 2.55).abs() < 1e-12);
        assert!((S.output_ideal(-10.0) - 0.75).abs() < 1e-12);
        assert!((S.amps(S.output_ideal(7.25)) - 7.25).abs() < 1e-12);
    }

    #[test]
    fn ratiometric_with_supply() {
        let s5 = HallCurrentSensor { vcc: 5.0, ..S };
        assert_eq!(s5.output_ideal(0.0), 2.5);
        assert!((s5.sensitivity() - 0.090 * 5.0 / 3.3).abs() < 1e-12);
    }

    #[test]
    fn saturates_near_the_rails() {
        // (1.65 − 0.05)/0.09 = 17.8 A before the output saturates.
        assert!((S.linear_range() - 1.6 / 0.09).abs() < 1e-12);
        assert_eq!(S.output_ideal(40.0), 3.25);
        assert_eq!(S.output_ideal(-40.0), 0.05);
    }

    #[test]
    fn noise_spread() {
        // 20 000 reads at 0 A: σ 6 mV, standard error of σ 6 mV/√40 000 = 0.03 mV; 5σ.
        let mut n = Noise::new(3, 3);
        let xs: Vec<f64> = (0..20_000).map(|_| S.output(0.0, &mut n)).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
        assert!((mean - 1.65).abs() < 5.0 * 0.006 / (20_000f64).sqrt(), "{mean}");
        assert!((sd - 0.006).abs() < 5.0 * 0.006 / (40_000f64).sqrt(), "{sd}");
    }
}
