//! The frames the receive interrupt captured, waiting for the driver: both stamps of each
//! (the controller's start-of-frame counter and the node's clock at the interrupt).

use rtcan::Micros;

/// Frames the ring holds: both hardware FIFOs' worth.
pub const RING: usize = 6;

/// A frame as the interrupt read it from a FIFO mailbox.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Captured {
    /// 29-bit identifier; `None` for a standard-identifier or remote frame (not RTCAN).
    pub raw_id: Option<u32>,
    /// Data length (0…8).
    pub len: u8,
    /// Data bytes (the first `len` are the frame's).
    pub data: [u8; 8],
    /// The time-triggered counter at the frame's start of frame.
    pub time: u16,
    /// The node's clock (µs) when the interrupt ran.
    pub stamped_at: Micros,
}

/// A free slot's content. All zero bytes (`raw_id: None` is a zero tag), unlike an
/// `Option<Captured>`'s `None` (a niche in `raw_id`'s tag), so the ring's static goes to `.bss`
/// instead of carrying 224 B of initial values in flash.
const FREE: Captured = Captured { raw_id: None, len: 0, data: [0; 8], time: 0, stamped_at: 0 };

/// Captured frames, oldest first; a frame that finds the ring full is counted and dropped
/// (the driver did not keep up), never one already captured.
#[derive(Debug)]
pub struct RxRing {
    /// Slots `head .. head + len` (modulo [`RING`]) hold frames; the others are stale.
    buf: [Captured; RING],
    head: usize,
    len: usize,
    overruns: u32,
}

impl Default for RxRing {
    fn default() -> Self {
        Self::new()
    }
}

impl RxRing {
    /// Empty.
    pub const fn new() -> Self {
        Self { buf: [FREE; RING], head: 0, len: 0, overruns: 0 }
    }

    /// Forgets every frame (the overrun count stays).
    pub fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
    }

    /// Adds `c`, or counts an overrun if the ring is full.
    pub fn push(&mut self, c: Captured) {
        if self.len == RING {
            self.overruns = self.overruns.wrapping_add(1);
            return;
        }
        self.buf[(self.head + self.len) % RING] = c;
        self.len += 1;
    }

    /// The oldest frame.
    pub fn take(&mut self) -> Option<Captured> {
        if self.len == 0 {
            return None;
        }
        let c = self.buf[self.head];
        self.head = (self.head + 1) % RING;
        self.len -= 1;
        Some(c)
    }

    /// Frames dropped because the ring was full.
    pub const fn overruns(&self) -> u32 {
        self.overruns
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(n: u8) -> Captured {
        Captured {
            raw_id: Some(u32::from(n)),
            len: 1,
            data: [n; 8],
            time: n.into(),
            stamped_at: n.into(),
        }
    }

    #[test]
    fn frames_come_out_in_arrival_order_and_a_full_ring_drops_the_newcomer() {
        let mut r = RxRing::new();
        assert_eq!(r.take(), None);
        for n in 0..8 {
            r.push(frame(n));
        }
        assert_eq!(r.overruns(), 2, "frames 6 and 7 found it full");
        for n in 0..6 {
            assert_eq!(r.take(), Some(frame(n)), "the captured ones are kept");
        }
        assert_eq!(r.take(), None);
        // Around the buffer's end, in order.
        for n in 10..30 {
            r.push(frame(n));
            assert_eq!(r.take(), Some(frame(n)));
        }
        r.push(frame(1));
        r.clear();
        assert_eq!((r.take(), r.overruns()), (None, 2));
    }
}
