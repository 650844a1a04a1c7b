//! The readings of one control step: the encoder on TIM3, the Hall current sensor and the
//! motor supply on ADC1.
//!
//! The current is sampled in step with the PWM, as the motor's ripple demands: ADC1's injected
//! group converts MOTOR_CURRENT then VMOT_SENSE at each of TIM1's update events, which in its
//! centre-aligned count fall at the top and the bottom of the triangle, the middles of the high
//! sides' on and off times, where the winding's current crosses its average (its ripple is up
//! to 2.8 A peak to peak at 36 V: hardware/motor). A step reads the latest pair, at most half a
//! PWM period (25 µs) old. A conversion the step started itself would land anywhere in the
//! period and err by up to half the ripple (±1.4 A). The emulated board (firmware/host/world's
//! H-bridge) reads the average for this reason.

use embassy_stm32::adc::{Adc, SampleTime};
use embassy_stm32::gpio::AfioRemap;
use embassy_stm32::pac;
use embassy_stm32::peripherals::{ADC1, PA0, PA1, PA6, PA7, TIM3};
use embassy_stm32::timer::qei::{Config, Qei};
use embassy_stm32::timer::{Ch1, Ch2};
use embassy_stm32::Peri;
use module_core::analog_input;

use crate::board::{MOTOR_CURRENT_ADC_CHANNEL, VMOT_SENSE_ADC_CHANNEL};

/// ADC sampling time: 28.5 cycles at 12 MHz (2.4 µs; 3.4 µs per conversion, 6.8 µs for the
/// pair, well inside the 25 µs between triggers), long enough for the Hall sensor's and the
/// divider's RC filters to charge the sampling capacitor.
const SAMPLE_TIME: SampleTime = SampleTime::CYCLES28_5;

/// JEXTSEL: the injected group's trigger, TIM1's TRGO (RM0008, ADC_CR2), which bridge.rs sets
/// to TIM1's update event.
const JEXTSEL_TIM1_TRGO: u8 = 0b000;

/// What the board measures.
pub struct Sensors {
    /// Powered and calibrated by embassy; its injected group is programmed here (embassy's F1
    /// driver converts one channel at a time, started by software).
    _adc: Adc<'static, ADC1>,
    qei: Qei<'static, TIM3>,
}

impl Sensors {
    /// ADC1's injected group on MOTOR_CURRENT and VMOT_SENSE (put in analog mode), triggered
    /// by TIM1 (bridge.rs sets TRGO); TIM3 in encoder mode (both edges of both channels: 4
    /// counts per line) on ENC_A and ENC_B.
    pub fn new(
        adc: Peri<'static, ADC1>,
        current: Peri<'static, PA0>,
        vmot: Peri<'static, PA1>,
        tim: Peri<'static, TIM3>,
        enc_a: Peri<'static, PA6>,
        enc_b: Peri<'static, PA7>,
    ) -> Self {
        // Analog mode; the channels are programmed by number below.
        let _ = (analog_input(current), analog_input(vmot));
        let adc = Adc::new(adc);
        let (i, v) = (MOTOR_CURRENT_ADC_CHANNEL, VMOT_SENSE_ADC_CHANNEL);
        let r = pac::ADC1;
        for ch in [i, v] {
            let ch = usize::from(ch);
            // Channels 0–9 in SMPR2, 10–17 in SMPR1.
            if ch < 10 {
                r.smpr2().modify(|w| w.set_smp(ch, SAMPLE_TIME));
            } else {
                r.smpr1().modify(|w| w.set_smp(ch - 10, SAMPLE_TIME));
            }
        }
        // Two conversions (JL = 1): the sequence is JSQ3 then JSQ4, their results JDR1, JDR2.
        r.jsqr().write(|w| {
            w.set_jl(1);
            w.set_jsq(2, i);
            w.set_jsq(3, v);
        });
        // Triggered injection needs SCAN set and JAUTO clear (RM0008 11.3.9).
        r.cr1().modify(|w| {
            w.set_scan(true);
            w.set_jauto(false);
        });
        r.cr2().modify(|w| {
            w.set_jextsel(JEXTSEL_TIM1_TRGO);
            w.set_jexttrig(true);
        });
        Self {
            _adc: adc,
            qei: Qei::new::<Ch1, Ch2, AfioRemap<0>>(tim, enc_a, enc_b, Config::default()),
        }
    }

    /// (encoder count, current ADC counts, VMOT ADC counts): the latest PWM-synchronous pair.
    pub fn read(&mut self) -> (u16, u16, u16) {
        let r = pac::ADC1;
        (self.qei.count(), r.jdr(0).read().jdata(), r.jdr(1).read().jdata())
    }
}
