//! The proximity application: one step per millisecond, sans-IO.

use r2p_module::leds;
use r2p_module::TopicNode;
use r2p_msgs::{Obstacle, Proximity};
use r2p_node::{NodeError, ParamStore};

use crate::channel::{Channel, Status};
use crate::curves::curve;
use crate::endpoints::Endpoints;
use crate::params::{Config, CHANNELS};

/// What the board-support layer reads before each step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sample {
    /// ADC codes of `PROX_CH0` … `PROX_CH3`.
    pub adc: [u16; CHANNELS],
    /// The node's state for the status LEDs (running, synced, traffic, storage fault).
    pub status: leds::Status,
    /// `SENSOR_PWR_FAULT` asserted (logical: `true` = the sensors' 5 V switch reports
    /// over-current and holds them at its current limit).
    pub supply_fault: bool,
}

/// What the board-support layer applies after each step (logical levels: `true` = on).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Command {
    /// `SENSOR_PWR_EN`: the sensors' 5 V supply.
    pub sensor_power: bool,
    /// `LED_STATUS`.
    pub led_status: bool,
    /// `LED_BUS`.
    pub led_bus: bool,
    /// `LED_FAULT`.
    pub led_fault: bool,
}

/// The proximity module's default application (the paper's Listing 1, with filtering and
/// hysteresis).
pub struct App<'a> {
    ep: Endpoints<'a>,
    params: &'a dyn ParamStore,
    channels: [Channel; CHANNELS],
    /// Per channel: may report an obstacle (re-armed once the channel reads clear).
    armed: [bool; CHANNELS],
    /// The switch's fault flag as last read.
    supply_fault: bool,
    next_publish_us: u64,
}

impl<'a> App<'a> {
    /// The application on its endpoints ([`crate::Storage::build`]) and parameter store.
    pub fn new(endpoints: Endpoints<'a>, params: &'a dyn ParamStore) -> Self {
        Self {
            ep: endpoints,
            params,
            channels: [Channel::default(); CHANNELS],
            armed: [true; CHANNELS],
            supply_fault: false,
            next_publish_us: 0,
        }
    }

    /// Exports `ranges` and `obstacle` on the module's node.
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        node.export(self.ep.ranges.remote)?;
        node.export(self.ep.obstacle.remote)?;
        Ok(())
    }

    /// The endpoints (topics to subscribe to on the module, publishers' statistics).
    pub fn endpoints(&self) -> &Endpoints<'a> {
        &self.ep
    }

    /// What the four channels read now and the supply switch's fault flag (what `ranges` last
    /// carried or would carry now).
    pub fn ranges(&self) -> Proximity {
        let s = self.channels.map(|c| c.status());
        Proximity {
            distance: s.map(Status::distance),
            status: s.map(Status::code),
            supply_fault: self.supply_fault,
        }
    }

    /// One step at `now_us`: read the supply's fault flag, filter and convert the four
    /// channels, report obstacles, publish `ranges` when due; returns the outputs to apply.
    pub fn step(&mut self, now_us: u64, sample: &Sample) -> Command {
        let cfg = Config::read(self.params);
        self.supply_fault = sample.supply_fault;
        for c in 0..CHANNELS {
            let kind = cfg.sensors[c];
            let status = self.channels[c].update(
                now_us,
                sample.adc[c],
                kind,
                cfg.sensor_power,
                cfg.filter_tau_us,
            );
            self.obstacle(c, kind, status, &cfg);
        }
        if now_us >= self.next_publish_us {
            self.next_publish_us = next_due(self.next_publish_us, now_us, cfg.period_us);
            let ranges = self.ranges();
            self.ep.ranges.publisher.publish_with(|m| *m = ranges);
        }
        let [led_status, led_bus, led_fault] = leds::levels(sample.status, now_us / 1000);
        Command { sensor_power: cfg.sensor_power, led_status, led_bus, led_fault }
    }

    /// Listing 1's `if (measure < THRESHOLD) obstacle_pub.publish(...)`, once per approach: a
    /// channel reports when it reads nearer than the threshold (or too near to measure, with
    /// the sensor's nearest distance: the target is at most that far), then stays quiet until
    /// it reads farther than threshold + hysteresis, too far, or no sensor.
    fn obstacle(&mut self, channel: usize, kind: u32, status: Status, cfg: &Config) {
        let near = match status {
            Status::Ok(d) => d < cfg.obstacle_m,
            Status::TooNear => true,
            Status::TooFar | Status::NoSensor => false,
        };
        let clear = match status {
            Status::Ok(d) => d > cfg.obstacle_m + cfg.obstacle_hysteresis_m,
            Status::TooNear => false,
            Status::TooFar | Status::NoSensor => true,
        };
        if self.armed[channel] && near {
            let distance = match (status, curve(kind)) {
                (Status::Ok(d), _) => d,
                (_, Some(c)) => c.min_range_m,
                (_, None) => 0.0,
            };
            let m = Obstacle { channel: channel as u8, distance };
            // SRT: never waits; an empty pool is counted by the publisher and retried next step.
            if self.ep.obstacle.publisher.publish_with(|o| *o = m).is_some() {
                self.armed[channel] = false;
            }
        } else if !self.armed[channel] && clear {
            self.armed[channel] = true;
        }
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
