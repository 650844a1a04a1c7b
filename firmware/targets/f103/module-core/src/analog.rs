//! A module's analog inputs on ADC1, converted one after the other: what the PSU (battery and
//! bus voltages, current), the proximity module (four sensors) and the motor (current, supply)
//! read at each step. embassy's F1 ADC converts one channel at a time (no scan, no DMA).

use embassy_stm32::adc::{Adc, AdcChannel, AnyAdcChannel, SampleTime};
use embassy_stm32::gpio::{Flex, Pin};
use embassy_stm32::peripherals::ADC1;
use embassy_stm32::Peri;

/// `N` channels of ADC1 and the sampling time they are converted with.
pub struct AnalogInputs<const N: usize> {
    adc: Adc<'static, ADC1>,
    channels: [AnyAdcChannel<'static, ADC1>; N],
    sample_time: SampleTime,
}

impl<const N: usize> AnalogInputs<N> {
    /// ADC1 on `channels` (each made by [`analog_input`]), converting each in `sample_time`.
    pub fn new(
        adc: Peri<'static, ADC1>,
        channels: [AnyAdcChannel<'static, ADC1>; N],
        sample_time: SampleTime,
    ) -> Self {
        Self { adc: Adc::new(adc), channels, sample_time }
    }

    /// Converts each channel, in order: the counts (12 bits).
    pub async fn read(&mut self) -> [u16; N] {
        let mut counts = [0; N];
        for (i, count) in counts.iter_mut().enumerate() {
            *count = self.adc.read(&mut self.channels[i], self.sample_time).await;
        }
        counts
    }
}

/// A board file's `analog` pin as a channel of ADC1, in analog mode (embassy's F1 ADC leaves
/// pins as floating inputs; dropping a `Flex` leaves its pin disconnected, which is analog on
/// the F1).
pub fn analog_input<P: Pin>(mut pin: Peri<'static, P>) -> AnyAdcChannel<'static, ADC1>
where
    Peri<'static, P>: AdcChannel<ADC1>,
{
    drop(Flex::new(pin.reborrow()));
    pin.degrade_adc()
}
