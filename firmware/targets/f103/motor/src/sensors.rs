//! The readings of one control step: the encoder on TIM3, the Hall current sensor and the
//! motor supply on ADC1.

use embassy_stm32::adc::SampleTime;
use embassy_stm32::gpio::AfioRemap;
use embassy_stm32::peripherals::{ADC1, PA0, PA1, PA6, PA7, TIM3};
use embassy_stm32::timer::qei::{Config, Qei};
use embassy_stm32::timer::{Ch1, Ch2};
use embassy_stm32::Peri;
use module_core::{analog_input, AnalogInputs};

/// ADC sampling time: 28.5 cycles at 12 MHz (2.4 µs; 3.4 µs per conversion), long enough for
/// the Hall sensor's and the divider's RC filters to charge the sampling capacitor.
const SAMPLE_TIME: SampleTime = SampleTime::CYCLES28_5;

/// What the board measures.
pub struct Sensors {
    /// MOTOR_CURRENT, VMOT_SENSE.
    analog: AnalogInputs<2>,
    qei: Qei<'static, TIM3>,
}

impl Sensors {
    /// ADC1 on MOTOR_CURRENT and VMOT_SENSE (put in analog mode), TIM3 in encoder mode (both
    /// edges of both channels: 4 counts per line) on ENC_A and ENC_B.
    pub fn new(
        adc: Peri<'static, ADC1>,
        current: Peri<'static, PA0>,
        vmot: Peri<'static, PA1>,
        tim: Peri<'static, TIM3>,
        enc_a: Peri<'static, PA6>,
        enc_b: Peri<'static, PA7>,
    ) -> Self {
        Self {
            analog: AnalogInputs::new(
                adc,
                [analog_input(current), analog_input(vmot)],
                SAMPLE_TIME,
            ),
            qei: Qei::new::<Ch1, Ch2, AfioRemap<0>>(tim, enc_a, enc_b, Config::default()),
        }
    }

    /// (encoder count, current ADC counts, VMOT ADC counts).
    pub async fn read(&mut self) -> (u16, u16, u16) {
        let count = self.qei.count();
        let [current, vmot] = self.analog.read().await;
        (count, current, vmot)
    }
}
