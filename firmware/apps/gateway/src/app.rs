//! The gateway's 1 kHz step, sans-IO: the LEDs and `gateway/status`.

use r2p_module::leds::{self, Pattern};
use r2p_module::TopicNode;
use r2p_msgs::{Barometer, Battery, GatewayStatus, GnssFix, Imu, MagneticField, R2pMessage};

use crate::endpoints::MIRRORED;

/// The latest message of a mirrored topic, packed as on the bus, and how many came so far
/// (the ROS side publishes each new one once: most are events).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Mirrored {
    /// The packed bytes (`len` of them).
    pub bytes: [u8; MIRROR_MAX],
    /// Bytes used.
    pub len: u8,
    /// Messages received so far.
    pub count: u32,
}

/// Largest mirrored message.
pub const MIRROR_MAX: usize = 16;

impl Mirrored {
    fn update<T: R2pMessage>(&mut self, m: &T) {
        if let Ok(n) = m.encode(&mut self.bytes) {
            self.len = n as u8;
            self.count = self.count.wrapping_add(1);
        }
    }

    /// The packed message.
    pub fn packed(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }
}
use r2p_node::NodeError;

use crate::endpoints::Endpoints;
use crate::link::BusLink;

/// Period of `gateway/status`, µs.
pub const STATUS_PERIOD_US: u64 = 1_000_000;

/// The network as the board-support layer sees it (the MCU: embassy-net's stack; the emulator:
/// its host listener).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NetState {
    /// The Ethernet link is up.
    pub link_up: bool,
    /// The IPv4 address in use, if any.
    pub ip: Option<[u8; 4]>,
    /// It came from DHCP.
    pub dhcp: bool,
    /// ROS samples the Zenoh bridge's write filter held back (`RosStats::filtered`): the
    /// bridge runs beside the step, so its count comes in with the network's state.
    pub ros_filtered: u32,
}

/// What the board-support layer reads before each step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sample {
    /// The node's state for the status LEDs (running, synced, traffic, storage fault).
    pub status: leds::Status,
    /// The network.
    pub net: NetState,
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
    /// `LED_LINK`: off without a link, fast blink with a link but no address yet, on with an
    /// address, a short blink off while a client is connected.
    pub led_link: bool,
}

/// The gateway's application.
pub struct App<'a> {
    ep: Endpoints<'a>,
    link: &'a BusLink,
    next_status_us: u64,
    battery: Option<Battery>,
    imu: Option<Imu>,
    mag: Option<MagneticField>,
    baro: Option<Barometer>,
    gnss: Option<GnssFix>,
    mirrored: [Mirrored; MIRRORED.len()],
}

impl<'a> App<'a> {
    /// The application on its endpoints ([`crate::Storage::build`]) and the link its server
    /// and bus tap share.
    pub fn new(endpoints: Endpoints<'a>, link: &'a BusLink) -> Self {
        Self {
            ep: endpoints,
            link,
            next_status_us: 0,
            battery: None,
            imu: None,
            mag: None,
            baro: None,
            gnss: None,
            mirrored: [Mirrored::default(); MIRRORED.len()],
        }
    }

    /// Exports `gateway/status` on the gateway's node and imports what ROS 2 gets besides the
    /// base's topics (the battery, the IMU; waiting harmlessly on a robot without them).
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        node.export(self.ep.status.remote)?;
        node.import(self.ep.battery.remote)?;
        node.import(self.ep.imu.remote)?;
        node.import(self.ep.mag.remote)?;
        node.import(self.ep.baro.remote)?;
        node.import(self.ep.gnss.remote)?;
        node.import(self.ep.psu_state.remote)?;
        node.import(self.ep.psu_event.remote)?;
        for f in &self.ep.motor_faults {
            node.import(f.remote)?;
        }
        Ok(())
    }

    /// The latest message of each [`MIRRORED`] topic, in its order.
    pub fn mirrored(&self) -> [Mirrored; MIRRORED.len()] {
        self.mirrored
    }

    /// The latest battery reading received, if any.
    pub fn battery(&self) -> Option<Battery> {
        self.battery
    }

    /// The latest IMU reading received, if any.
    pub fn imu(&self) -> Option<Imu> {
        self.imu
    }

    /// The latest magnetic field, barometer reading and GNSS fix from the IMU module, if any.
    pub fn imu_extras(&self) -> (Option<MagneticField>, Option<Barometer>, Option<GnssFix>) {
        (self.mag, self.baro, self.gnss)
    }

    /// The endpoints.
    pub fn endpoints(&self) -> &Endpoints<'a> {
        &self.ep
    }

    /// The status as published now.
    pub fn status(&self, net: &NetState) -> GatewayStatus {
        use core::sync::atomic::Ordering::Relaxed;
        let s = &self.link.stats;
        GatewayStatus {
            link_up: net.link_up,
            configured: net.ip.is_some(),
            dhcp: net.ip.is_some() && net.dhcp,
            ip: net.ip.map_or(0, u32::from_be_bytes),
            clients: self.link.clients(),
            frames_to_clients: s.frames_to_clients.load(Relaxed),
            frames_from_clients: s.frames_from_clients.load(Relaxed),
            client_errors: s.client_errors.load(Relaxed),
            lost: s.lost.load(Relaxed),
            ros_filtered: net.ros_filtered,
        }
    }

    /// One step at `now_us`: `gateway/status` when due; returns the LEDs.
    pub fn step(&mut self, now_us: u64, sample: &Sample) -> Command {
        while let Some(b) = self.ep.battery.subscriber.try_recv() {
            self.battery = Some(*b);
        }
        while let Some(m) = self.ep.imu.subscriber.try_recv() {
            self.imu = Some(*m);
        }
        while let Some(m) = self.ep.mag.subscriber.try_recv() {
            self.mag = Some(*m);
        }
        while let Some(m) = self.ep.baro.subscriber.try_recv() {
            self.baro = Some(*m);
        }
        while let Some(m) = self.ep.gnss.subscriber.try_recv() {
            self.gnss = Some(*m);
        }
        while let Some(m) = self.ep.psu_state.subscriber.try_recv() {
            self.mirrored[0].update(&*m);
        }
        while let Some(m) = self.ep.psu_event.subscriber.try_recv() {
            self.mirrored[1].update(&*m);
        }
        for (i, f) in self.ep.motor_faults.iter().enumerate() {
            while let Some(m) = f.subscriber.try_recv() {
                self.mirrored[2 + i].update(&*m);
            }
        }
        if now_us >= self.next_status_us {
            let next = self.next_status_us + STATUS_PERIOD_US;
            self.next_status_us = if next <= now_us { now_us + STATUS_PERIOD_US } else { next };
            let status = self.status(&sample.net);
            self.ep.status.publisher.publish_with(|m| *m = status);
        }
        let now_ms = now_us / 1000;
        let [led_status, led_bus, led_fault] = leds::levels(sample.status, now_ms);
        let link = match (sample.net.link_up, sample.net.ip.is_some(), self.link.clients() > 0) {
            (false, _, _) => Pattern::Off,
            (true, false, _) => leds::FAST,
            (true, true, false) => Pattern::On,
            // Lit 90 % of each second: "someone is connected", still reads as "on".
            (true, true, true) => Pattern::Blink { period_ms: 1000 }.with_duty(now_ms, 900),
        };
        Command { led_status, led_bus, led_fault, led_link: link.is_lit(now_ms) }
    }
}

/// A pattern evaluated with its own duty cycle.
trait Duty {
    fn with_duty(self, now_ms: u64, lit_ms: u64) -> Pattern;
}

impl Duty for Pattern {
    fn with_duty(self, now_ms: u64, lit_ms: u64) -> Pattern {
        match self {
            Pattern::Blink { period_ms } if now_ms % u64::from(period_ms.max(1)) < lit_ms => {
                Pattern::On
            }
            Pattern::Blink { .. } => Pattern::Off,
            other => other,
        }
    }
}
