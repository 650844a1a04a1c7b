//! The MCU's ADC: what the firmware reads for a voltage on an analog pin.
//!
//! STM32F103 ADC1: 12 bits, reference VDDA = 3.3 V on the R2P modules. Model: the pin voltage
//! plus Gaussian input-referred noise, quantised to the nearest code (code k covers
//! (k − ½, k + ½] LSB, 1 LSB = Vref/4096) and clipped to 0..4095. Not modelled: offset, gain
//! and integral non-linearity errors (datasheet TUE ±2 LSB typ), sampling-capacitor charge
//! sharing with high source impedances.

use crate::noise::Noise;

/// An ADC's transfer characteristic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adc {
    /// Resolution, bits.
    pub bits: u32,
    /// Reference voltage (full scale), V.
    pub vref: f64,
    /// Input-referred noise, LSB rms.
    pub noise_lsb: f64,
}

impl Adc {
    /// The STM32F103's ADC at 3.3 V with 1 LSB rms of noise (an assumption: the datasheet
    /// gives no noise figure; 1 LSB matches a quiet board, ENOB ≈ 11).
    pub const STM32F103: Adc = Adc { bits: 12, vref: 3.3, noise_lsb: 1.0 };

    /// Volts per code.
    pub fn lsb(&self) -> f64 {
        self.vref / f64::from(1u32 << self.bits)
    }

    /// Largest code.
    pub fn max_code(&self) -> u16 {
        ((1u32 << self.bits) - 1) as u16
    }

    /// The code for `volts` on the pin, with a noise draw from `noise`.
    pub fn convert(&self, volts: f64, noise: &mut Noise) -> u16 {
        let x = volts / self.lsb() + noise.gaussian(self.noise_lsb);
        self.quantise(x)
    }

    /// The code for `volts` without noise.
    pub fn convert_ideal(&self, volts: f64) -> u16 {
        self.quantise(volts / self.lsb())
    }

    fn quantise(&self, lsbs: f64) -> u16 {
        // Round half up, clip at both ends (NaN reads as 0, like a floating input pulled low).
        let c = (lsbs + 0.5).floor();
        if c.is_nan() || c <= 0.0 {
            0
        } else {
            c.min(f64::from(self.max_code())) as u16
        }
    }

    /// The voltage at the centre of `code`'s bin (what firmware takes a code to mean).
    pub fn volts(&self, code: u16) -> f64 {
        f64::from(code) * self.lsb()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ADC: Adc = Adc::STM32F103;

    #[test]
    fn quantisation_and_clipping() {
        assert_eq!(ADC.lsb(), 3.3 / 4096.0);
        assert_eq!(ADC.convert_ideal(0.0), 0);
        assert_eq!(ADC.convert_ideal(1.65), 2048);
        // Half an LSB either side of a code's centre.
        let l = ADC.lsb();
        assert_eq!(ADC.convert_ideal(1000.0 * l + 0.49 * l), 1000);
        assert_eq!(ADC.convert_ideal(1000.0 * l + 0.51 * l), 1001);
        assert_eq!(ADC.convert_ideal(-0.2), 0);
        assert_eq!(ADC.convert_ideal(3.3), 4095);
        assert_eq!(ADC.convert_ideal(5.0), 4095);
        assert_eq!(ADC.convert_ideal(f64::NAN), 0);
    }

    #[test]
    fn noise_has_the_stated_spread() {
        // Mid-scale plus N(0, 1 LSB²) noise: codes scatter with σ² = 1 + 1/12 (quantisation);
        // n = 20 000 → standard error of the mean 0.0074 LSB, of σ ≈ 0.0052 LSB; 5σ bounds.
        let mut n = Noise::new(5, 1);
        let v = 2000.0 * ADC.lsb();
        let xs: Vec<f64> = (0..20_000).map(|_| f64::from(ADC.convert(v, &mut n))).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
        assert!((mean - 2000.0).abs() < 5.0 * 0.0074, "{mean}");
        let expect = (1.0f64 + 1.0 / 12.0).sqrt();
        assert!((sd - expect).abs() < 5.0 * 0.0052, "{sd} vs {expect}");
    }
}
