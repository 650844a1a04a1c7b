//! Model of a Benewake TFmini-S on a [`SimUart`], fed by the world's [`Lidar`] model.
//!
//! Streams one 9-byte data frame (format in `r2p_drivers::tfmini`) every 1/frame-rate
//! (100 Hz at power-up), each with what the world's [`Lidar`] measures at that moment, and
//! answers the "set frame rate" command (`5A 06 03 rate_L rate_H sum`) by echoing it and
//! switching rate from the next frame; rate 0 stops the stream. Other well-formed commands
//! are counted and ignored; malformed ones are dropped (the sensor's behaviour for them is not
//! documented).
//!
//! Timing: a frame due at t is put on the wire at t (the UART paces its bytes), provided the
//! model is updated before the line is advanced past t ([`TfminiModel::update`] then
//! [`SimUart::advance_to`], every millisecond in the emulator: frames are sampled at the
//! millisecond step, their bytes timed exactly).

use r2p_drivers::tfmini::{checksum, Frame, CMD_FRAME_RATE, COMMAND_HEADER};
use r2p_world::lidar::Lidar;
use r2p_world::World;

use super::uart::SimUart;

/// Frame rate at power-up, Hz.
pub const DEFAULT_FRAME_RATE_HZ: u16 = 100;

/// The sensor's state.
#[derive(Clone, Debug)]
pub struct TfminiModel {
    rate_hz: u16,
    next_ns: u64,
    command: Vec<u8>,
    frames: u64,
    commands: u64,
}

impl Default for TfminiModel {
    fn default() -> Self {
        Self::new()
    }
}

impl TfminiModel {
    /// A sensor just powered up: first frame one period from time 0.
    pub fn new() -> Self {
        Self {
            rate_hz: DEFAULT_FRAME_RATE_HZ,
            next_ns: period_ns(DEFAULT_FRAME_RATE_HZ),
            command: Vec::new(),
            frames: 0,
            commands: 0,
        }
    }

    /// Frame rate now, Hz.
    pub fn frame_rate_hz(&self) -> u16 {
        self.rate_hz
    }

    /// Frames sent so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Well-formed commands received.
    pub fn commands(&self) -> u64 {
        self.commands
    }

    /// Handles what the MCU sent, then sends the frames due by `now_ns` with what `lidar`
    /// sees of `world`.
    pub fn update(&mut self, now_ns: u64, uart: &mut SimUart, lidar: &mut Lidar, world: &World) {
        for b in uart.device_receive() {
            self.command_byte(b, now_ns, uart);
        }
        while self.rate_hz > 0 && self.next_ns <= now_ns {
            let r = lidar.measure(&world.pose(), world.obstacles());
            let f = Frame { dist: r.dist_cm, strength: r.strength, temp: r.temp };
            uart.device_send_at(self.next_ns, &f.encode());
            self.frames += 1;
            self.next_ns += period_ns(self.rate_hz);
        }
    }

    fn command_byte(&mut self, b: u8, now_ns: u64, uart: &mut SimUart) {
        if self.command.is_empty() && b != COMMAND_HEADER {
            return;
        }
        self.command.push(b);
        let Some(&len) = self.command.get(1) else { return };
        if !(4..=32).contains(&len) {
            self.command.clear();
            return;
        }
        if self.command.len() < usize::from(len) {
            return;
        }
        let cmd = std::mem::take(&mut self.command);
        let (body, sum) = cmd.split_at(cmd.len() - 1);
        if checksum(body) != sum[0] {
            return;
        }
        self.commands += 1;
        if cmd[2] == CMD_FRAME_RATE && cmd.len() == 6 {
            let was_off = self.rate_hz == 0;
            self.rate_hz = u16::from_le_bytes([cmd[3], cmd[4]]);
            uart.device_send_at(now_ns, &cmd);
            if self.rate_hz > 0 {
                let p = period_ns(self.rate_hz);
                self.next_ns = if was_off { now_ns + p } else { self.next_ns.max(now_ns) };
            }
        }
    }
}

fn period_ns(hz: u16) -> u64 {
    1_000_000_000 / u64::from(hz.max(1))
}
