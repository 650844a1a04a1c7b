//! The quadrature encoder: TIM3's 16-bit count extended to 32 bits, and its scale to radians.
//!
//! The timer counts up and down by one per quadrature edge and wraps at 16 bits. Read every
//! control step (1 ms), the change since the last read is the 16-bit difference taken as
//! signed: correct as long as the shaft moves less than 32 767 counts per step (at 2000 counts
//! per revolution, 16 000 revolutions per second). The 32-bit count wraps too (two's
//! complement), so speeds from count differences stay right across that wrap as well.

/// A 16-bit hardware count extended to 32 bits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Encoder {
    last_raw: u16,
    count: i32,
    started: bool,
}

impl Encoder {
    /// An encoder whose first reading becomes count 0.
    pub const fn new() -> Self {
        Self { last_raw: 0, count: 0, started: false }
    }

    /// Takes the timer's count `raw`; returns the extended count.
    pub fn update(&mut self, raw: u16) -> i32 {
        if self.started {
            let delta = raw.wrapping_sub(self.last_raw) as i16;
            self.count = self.count.wrapping_add(i32::from(delta));
        }
        self.started = true;
        self.last_raw = raw;
        self.count
    }

    /// The extended count (0 before the first reading).
    pub fn count(&self) -> i32 {
        self.count
    }
}

/// Counts to output-shaft radians: an encoder of `lines` per motor revolution (4 counts per
/// line: both edges of both channels) through a `gear_ratio`:1 gearbox.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    /// Output-shaft radians per count.
    pub rad_per_count: f32,
}

impl Scale {
    /// The scale of an encoder with `lines` per motor revolution and a gearbox of
    /// `gear_ratio` motor revolutions per output revolution.
    pub fn new(lines: u32, gear_ratio: f32) -> Self {
        Self { rad_per_count: core::f32::consts::TAU / (4.0 * lines as f32 * gear_ratio) }
    }

    /// Output-shaft position of `count`, rad. f32 keeps about one count of resolution up to
    /// 2^24 counts (560 output revolutions at 2000 counts × 15:1), a fraction of a degree beyond.
    pub fn position(&self, count: i32) -> f32 {
        count as f32 * self.rad_per_count
    }

    /// Output-shaft speed, rad/s, from the count difference `from` → `to` over `dt_s` seconds
    /// (wrapping difference: right across the 32-bit wrap).
    pub fn speed(&self, from: i32, to: i32, dt_s: f32) -> f32 {
        to.wrapping_sub(from) as f32 * self.rad_per_count / dt_s
    }
}
