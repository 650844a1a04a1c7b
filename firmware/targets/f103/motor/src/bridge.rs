//! The H-bridge: TIM1 drives both half-bridges with complementary PWM and dead time, its
//! break input (the gate driver's DRV_FAULT) cuts the outputs in hardware, DRV_EN enables the
//! driver.
//!
//! Sign-magnitude drive: for a positive duty leg A switches at `duty` and leg B stays low, for a
//! negative one the other way round, so the motor sees `duty × VMOT` on average and the
//! current recirculates through the low sides between pulses. Both legs low is the brake.
//! Bridge off: DRV_EN low and TIM1's main output enable cleared (every switch open: coasting).

use embassy_stm32::gpio::{AfioRemap, Input, Output, OutputType, Pull};
use embassy_stm32::peripherals::{PA8, PA9, PB12, PB13, PB14, TIM1};
use embassy_stm32::time::Hertz;
use embassy_stm32::timer::complementary_pwm::{
    BreakInputPolarity, ComplementaryPwm, ComplementaryPwmPin, Ossi,
};
use embassy_stm32::timer::low_level::CountingMode;
use embassy_stm32::timer::simple_pwm::PwmPin;
use embassy_stm32::timer::{BkIn1, BreakInputPin, Channel};
use embassy_stm32::{pac, Peri};
use r2p_app_motor::Command;

/// PWM frequency: above hearing, low enough for the gate driver's switching losses.
pub const PWM_HZ: u32 = 20_000;
/// Dead time TIM1 inserts between one switch of a leg opening and the other closing, ns: a
/// guard only. The gate driver (HIP4082) delays every turn-on by its own 200-850 ns (R_DEL
/// 10 k), which covers the MOSFETs' turn-off; more here would starve the bootstrap refresh at
/// the 0.95 duty limit (hardware/motor/README.md, r2ptools/kicad/calc/motor.py).
pub const DEAD_TIME_NS: u32 = 100;
/// TIM1's clock (APB2 at 72 MHz, timer clock = PCLK2), Hz.
const TIM1_CLOCK_HZ: u32 = crate::board::SYSCLK_HZ;
/// The dead time in TIM1 clock ticks (7 at 72 MHz: 97 ns).
const DEAD_TIME_TICKS: u16 = (DEAD_TIME_NS as u64 * TIM1_CLOCK_HZ as u64 / 1_000_000_000) as u16;

/// TIM1's pins as the board file gives them (no remap: TIM1_REMAP = 0).
pub struct Pins {
    /// Leg A high side (TIM1_CH1).
    pub ah: Peri<'static, PA8>,
    /// Leg A low side (TIM1_CH1N).
    pub al: Peri<'static, PB13>,
    /// Leg B high side (TIM1_CH2).
    pub bh: Peri<'static, PA9>,
    /// Leg B low side (TIM1_CH2N).
    pub bl: Peri<'static, PB14>,
    /// DRV_FAULT (TIM1_BKIN, active low).
    pub fault: Peri<'static, PB12>,
    /// DRV_EN (output, active high).
    pub enable: Output<'static>,
}

/// The bridge and its state.
pub struct Bridge {
    pwm: ComplementaryPwm<'static, TIM1>,
    enable: Output<'static>,
    _fault: Input<'static>,
    max_duty: u32,
}

/// DRV_FAULT as TIM1's break input: the pin trait refuses at compile time a pin that cannot be
/// TIM1_BKIN (without remap). An input on the F1 (alternate-function inputs need no AF mode);
/// the board pulls it up.
fn break_input<P: BreakInputPin<TIM1, BkIn1, AfioRemap<0>>>(
    pin: Peri<'static, P>,
) -> Input<'static> {
    Input::new(pin, Pull::None)
}

impl Bridge {
    /// TIM1 at [`PWM_HZ`], centre-aligned, with [`DEAD_TIME_NS`] and the break input armed, its
    /// update event as the ADC's trigger (TRGO); the bridge starts off.
    pub fn new(tim: Peri<'static, TIM1>, pins: Pins) -> Self {
        let pwm = ComplementaryPwm::new::<AfioRemap<0>>(
            tim,
            Some(PwmPin::new(pins.ah, OutputType::PushPull)),
            Some(ComplementaryPwmPin::new(pins.al, OutputType::PushPull)),
            Some(PwmPin::new(pins.bh, OutputType::PushPull)),
            Some(ComplementaryPwmPin::new(pins.bl, OutputType::PushPull)),
            None,
            None,
            None,
            None,
            Hertz(PWM_HZ),
            CountingMode::CenterAlignedBothInterrupts,
        );
        let mut b = Self {
            max_duty: pwm.get_max_duty(),
            pwm,
            enable: pins.enable,
            _fault: break_input(pins.fault),
        };
        b.off();
        // Outputs at their idle level (all switches open) whenever MOE is clear.
        b.pwm.set_off_state_selection_idle(Ossi::IDLE_LEVEL);
        b.pwm.set_dead_time(DEAD_TIME_TICKS);
        b.pwm.set_break_polarity(BreakInputPolarity::ACTIVE_LOW);
        b.pwm.set_break_enable(true);
        // After a break MOE stays clear until the application enables the bridge again.
        b.pwm.set_automatic_output_enable(false);
        b.set(0, 0);
        b.pwm.enable(Channel::Ch1);
        b.pwm.enable(Channel::Ch2);
        // TRGO on the update event: at the top and the bottom of the centre-aligned count, where
        // ADC1 samples the motor current (sensors.rs).
        pac::TIM1.cr2().modify(|w| w.set_mms(pac::timer::vals::Mms::UPDATE));
        take_break_flag();
        b
    }

    fn set(&mut self, a: u32, b: u32) {
        self.pwm.set_duty(Channel::Ch1, a);
        self.pwm.set_duty(Channel::Ch2, b);
    }

    fn off(&mut self) {
        self.pwm.set_master_output_enable(false);
        self.enable.set_low();
    }

    /// Applies the application's command.
    pub fn apply(&mut self, cmd: &Command) {
        if !cmd.bridge_enable {
            self.off();
            self.set(0, 0);
            return;
        }
        let duty = if cmd.brake { 0.0 } else { cmd.duty.clamp(-1.0, 1.0) };
        let ticks = (duty.abs() * self.max_duty as f32) as u32;
        if duty >= 0.0 {
            self.set(ticks, 0);
        } else {
            self.set(0, ticks);
        }
        self.enable.set_high();
        self.pwm.set_master_output_enable(true);
    }
}

/// Whether TIM1's break flag is set (the driver pulled DRV_FAULT since the last call); clears it.
pub fn take_break_flag() -> bool {
    let sr = pac::TIM1.sr();
    let set = sr.read().bif(0);
    if set {
        sr.modify(|w| w.set_bif(0, false));
    }
    set
}
