//! The PSU application: one step per millisecond, sans-IO.

use r2p_middleware::Publisher;
use r2p_module::filters::LowPass;
use r2p_module::leds;
use r2p_module::TopicNode;
use r2p_msgs::{Battery, PsuEvent, PsuState};
use r2p_node::{NodeError, ParamStore};

use crate::charge::{remaining_s, ChargeCounter};
use crate::endpoints::Endpoints;
use crate::event::{
    CAUSE_COMMAND, CAUSE_EFUSE, CAUSE_OVER_CURRENT, OUTPUT_OFF, OUTPUT_ON, OVER_CURRENT,
    UNDER_VOLTAGE, VOLTAGE_RECOVERED,
};
use crate::frontend::{iin_amps, vin_volts, vout_volts};
use crate::params::Config;
use crate::protection::{EfuseFault, Output, OverCurrent, UnderVoltage};

/// What the board-support layer reads before each step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sample {
    /// `VIN_SENSE` ADC code (battery voltage).
    pub vin: u16,
    /// `IIN_SENSE` ADC code (battery current).
    pub iin: u16,
    /// `VOUT_SENSE` ADC code (bus voltage).
    pub vout: u16,
    /// `BUS_FAULT` asserted (the eFuse flags a fault; logical level, the pin is active low).
    pub bus_fault: bool,
    /// The node's state for the status LEDs (running, synced, traffic, storage fault); the
    /// application adds its own faults.
    pub status: leds::Status,
}

/// What the board-support layer applies after each step (logical levels: `true` = on).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Command {
    /// `BUS_EN`: the 5 V bus output.
    pub bus_en: bool,
    /// `LED_STATUS`.
    pub led_status: bool,
    /// `LED_BUS`.
    pub led_bus: bool,
    /// `LED_FAULT`.
    pub led_fault: bool,
}

/// The PSU's default application.
pub struct App<'a> {
    ep: Endpoints<'a>,
    params: &'a dyn ParamStore,
    last_us: Option<u64>,
    next_publish_us: u64,
    voltage: Smoothed,
    current: Smoothed,
    bus_voltage: Smoothed,
    charge: ChargeCounter,
    over_current: OverCurrent,
    under_voltage: UnderVoltage,
    efuse: EfuseFault,
    output: Output,
    battery: Battery,
}

impl<'a> App<'a> {
    /// The application on its endpoints ([`crate::Storage::build`]) and parameter store.
    pub fn new(endpoints: Endpoints<'a>, params: &'a dyn ParamStore) -> Self {
        Self {
            ep: endpoints,
            params,
            last_us: None,
            next_publish_us: 0,
            voltage: Smoothed::default(),
            current: Smoothed::default(),
            bus_voltage: Smoothed::default(),
            charge: ChargeCounter::default(),
            over_current: OverCurrent::default(),
            under_voltage: UnderVoltage::default(),
            efuse: EfuseFault::default(),
            output: Output::default(),
            battery: Battery::default(),
        }
    }

    /// Exports `battery`, `state` and `event` and imports `power` on the module's node.
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        node.export(self.ep.battery.remote)?;
        node.export(self.ep.state.remote)?;
        node.export(self.ep.event.remote)?;
        node.import(self.ep.power.remote)?;
        Ok(())
    }

    /// The endpoints (topics to subscribe to on the module, publishers' statistics).
    pub fn endpoints(&self) -> &Endpoints<'a> {
        &self.ep
    }

    /// The latest battery reading (what `battery` last carried or would carry now).
    pub fn battery(&self) -> Battery {
        self.battery
    }

    /// Whether the bus output is on.
    pub fn output_on(&self) -> bool {
        self.output.is_on()
    }

    /// One step at `now_us`: convert and filter, count charge, run the protections and the
    /// `power` commands, publish what is due; returns the outputs to apply.
    pub fn step(&mut self, now_us: u64, sample: &Sample) -> Command {
        let cfg = Config::read(self.params);
        let dt_us = self.last_us.map_or(0, |t| now_us.saturating_sub(t));
        self.last_us = Some(now_us);

        let tau = cfg.filter_tau_us;
        let amps = cfg.iin.apply(iin_amps(sample.iin));
        let volts = self.voltage.push(cfg.vin.apply(vin_volts(sample.vin)), tau);
        let amps_avg = self.current.push(amps, tau);
        let bus_volts = self.bus_voltage.push(cfg.vout.apply(vout_volts(sample.vout)), tau);
        self.charge.add(amps, dt_us);
        let event = |kind, cause| Event { kind, cause, voltage: volts, current: amps };

        while let Some(cmd) = self.ep.power.subscriber.try_recv() {
            if let Some(on) = self.output.command(cmd.on) {
                if on {
                    self.over_current = OverCurrent::default();
                    self.efuse = EfuseFault::default();
                }
                event(if on { OUTPUT_ON } else { OUTPUT_OFF }, CAUSE_COMMAND)
                    .send(self.ep.event.publisher);
            }
        }
        if self.over_current.update(now_us, amps, cfg.oc_threshold_a, cfg.oc_time_us) {
            event(OVER_CURRENT, 0).send(self.ep.event.publisher);
            if self.output.trip(CAUSE_OVER_CURRENT) {
                event(OUTPUT_OFF, CAUSE_OVER_CURRENT).send(self.ep.event.publisher);
            }
        }
        if self.efuse.update(now_us, sample.bus_fault, self.output.is_on())
            && self.output.trip(CAUSE_EFUSE)
        {
            event(OUTPUT_OFF, CAUSE_EFUSE).send(self.ep.event.publisher);
        }
        match self.under_voltage.update(volts, cfg.uv_threshold_v, cfg.uv_hysteresis_v) {
            Some(true) => event(UNDER_VOLTAGE, 0).send(self.ep.event.publisher),
            Some(false) => event(VOLTAGE_RECOVERED, 0).send(self.ep.event.publisher),
            None => {}
        }

        let used = self.charge.amp_hours();
        self.battery = Battery {
            voltage: volts,
            current: amps_avg,
            charge_used: used,
            remaining_s: remaining_s(cfg.capacity_ah, used, amps_avg),
        };
        if now_us >= self.next_publish_us {
            self.next_publish_us = next_due(self.next_publish_us, now_us, cfg.battery_period_us);
            let battery = self.battery;
            self.ep.battery.publisher.publish_with(|m| *m = battery);
            let state = PsuState {
                output_on: self.output.is_on(),
                latched: self.output.latched(),
                under_voltage: self.under_voltage.is_low(),
                bus_voltage: bus_volts,
            };
            self.ep.state.publisher.publish_with(|m| *m = state);
        }

        let fault = self.output.latched() != 0 || self.under_voltage.is_low();
        let [led_status, led_bus, led_fault] =
            leds::levels(leds::Status { fault, ..sample.status }, now_us / 1000);
        Command { bus_en: self.output.is_on(), led_status, led_bus, led_fault }
    }
}

/// The next publication time after `due` (one period on; if the step came late by more than
/// a period, one period from now so that a stall does not cause a burst).
fn next_due(due: u64, now_us: u64, period_us: u64) -> u64 {
    let next = due + period_us;
    if next <= now_us {
        now_us + period_us
    } else {
        next
    }
}

/// Period [`App::step`] is called with (the filters' sample time).
pub const STEP_S: f32 = 0.001;

/// A low-pass filter whose time constant is a parameter: rebuilt, from its present value, when
/// the parameter changes.
#[derive(Default)]
struct Smoothed {
    filter: Option<LowPass>,
    tau_us: u32,
}

impl Smoothed {
    fn push(&mut self, x: f32, tau_us: u32) -> f32 {
        if self.filter.is_none() || self.tau_us != tau_us {
            let cutoff_hz = 1e6 / (2.0 * core::f32::consts::PI * tau_us.max(1) as f32);
            let mut f = LowPass::new(cutoff_hz, STEP_S);
            if let Some(y) = self.filter.and_then(|f| f.value()) {
                f.push(y);
            }
            self.filter = Some(f);
            self.tau_us = tau_us;
        }
        self.filter.as_mut().map_or(x, |f| f.push(x))
    }
}

/// An event about to be published.
struct Event {
    kind: u8,
    cause: u8,
    voltage: f32,
    current: f32,
}

impl Event {
    /// Publishes it (SRT: never waits; an empty pool is counted by the publisher). Out of line:
    /// inlined, each of `step`'s eight events carried its own copy of the publication (256 B).
    #[inline(never)]
    fn send<'a>(self, publisher: &'a Publisher<'a, PsuEvent>) {
        publisher.publish_with(|m| {
            *m = PsuEvent {
                kind: self.kind,
                cause: self.cause,
                voltage: self.voltage,
                current: self.current,
            }
        });
    }
}
