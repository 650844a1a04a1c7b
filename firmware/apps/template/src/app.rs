//! The template application: one step per millisecond, sans-IO.

use r2p_module::leds;
use r2p_module::TopicNode;
use r2p_node::{NodeError, ParamStore};

use crate::endpoints::Endpoints;
use crate::params;

/// What the board-support layer reads before each step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sample {
    /// The node's state for the status LEDs (running, synced, traffic, storage fault).
    pub status: leds::Status,
}

/// What the board-support layer applies after each step (logical levels: `true` = on).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Command {
    /// `LED_STATUS`.
    pub led_status: bool,
    /// `LED_BUS`.
    pub led_bus: bool,
    /// `LED_FAULT`.
    pub led_fault: bool,
}

/// The template's application.
pub struct App<'a> {
    ep: Endpoints<'a>,
    params: &'a dyn ParamStore,
    steps: u32,
    next_publish_us: u64,
}

impl<'a> App<'a> {
    /// The application on its endpoints ([`crate::Storage::build`]) and parameter store.
    pub fn new(endpoints: Endpoints<'a>, params: &'a dyn ParamStore) -> Self {
        Self { ep: endpoints, params, steps: 0, next_publish_us: 0 }
    }

    /// Exports `count` on the module's node.
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        node.export(self.ep.count.remote)
    }

    /// The endpoints (the topic to subscribe to on the module, the publisher's statistics).
    pub fn endpoints(&self) -> &Endpoints<'a> {
        &self.ep
    }

    /// One step at `now_us`: count it, publish the count when due; returns the LEDs.
    pub fn step(&mut self, now_us: u64, sample: &Sample) -> Command {
        self.steps = self.steps.wrapping_add(1);
        if now_us >= self.next_publish_us {
            let period = params::period_us(self.params);
            // One period on; after a stall longer than a period, one period from now (no burst).
            let next = self.next_publish_us + period;
            self.next_publish_us = if next <= now_us { now_us + period } else { next };
            let steps = self.steps;
            self.ep.count.publisher.publish_with(|m| *m = steps);
        }
        let [led_status, led_bus, led_fault] = leds::levels(sample.status, now_us / 1000);
        Command { led_status, led_bus, led_fault }
    }
}
