//! A frame's start of frame in the node's µs, from what the controller captured.

use rtcan::time_counter::{valid_at_bits, TimeCounter};
use rtcan::{Frame, Micros};

/// A received frame's start of frame: its counter `capture` extended by `counter` (which the
/// frame also refines), read at `now`. Without a counter (a bit rate whose bit time is not a
/// whole number of µs) the interrupt's stamp less the frame's length: late by that
/// interrupt's latency.
pub fn received_start_of_frame(
    counter: Option<&mut TimeCounter>,
    frame: &Frame,
    capture: u16,
    stamped_at: Micros,
    now: Micros,
    bit_rate: u32,
) -> Micros {
    match counter {
        Some(tc) => tc.stamp_received(frame, capture, stamped_at, now),
        None => {
            let bit_us = 1_000_000 / bit_rate.max(1);
            stamped_at.saturating_sub(u64::from(valid_at_bits(frame) * bit_us))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sync() -> Frame {
        Frame::from_raw(0x0000_2280, &[6, 0, 0, 0, 0, 0, 0, 0]).unwrap()
    }

    #[test]
    fn with_a_counter_the_capture_gives_the_start_of_frame_exactly() {
        let f = sync();
        let len = u64::from(valid_at_bits(&f));
        let mut tc = TimeCounter::new(1_000_000);
        // Counter at phase 100: a frame starting at 5 000 µs captured 5 100; the interrupt
        // ran 4 µs after it became valid, the driver read it 300 µs later.
        let at = received_start_of_frame(tc.as_mut(), &f, 5_100, 5_000 + len, 5_300, 1_000_000);
        assert_eq!(at, 5_000);
        let at = received_start_of_frame(tc.as_mut(), &f, 9_100, 9_000 + len + 4, 9_300, 1_000_000);
        assert_eq!(at, 9_000, "the interrupt's latency is not in the stamp");
    }

    #[test]
    fn without_a_counter_the_frames_length_is_taken_off_the_interrupts_stamp() {
        let f = sync();
        let bits = u64::from(valid_at_bits(&f));
        // 500 kbit/s: 2 µs per bit time.
        assert_eq!(
            received_start_of_frame(None, &f, 0, 10_000, 10_500, 500_000),
            10_000 - 2 * bits
        );
        assert_eq!(received_start_of_frame(None, &f, 0, 3, 10, 500_000), 0, "never before 0");
    }
}
