//! A simulated UART between the MCU and a serial device, with bytes paced in virtual time.
//!
//! The MCU end implements `embedded_io::{Read, ReadReady, Write}` as embassy-stm32's
//! buffered/ring-buffered UART does on a module; the device end ([`SimUart::device_send_at`],
//! [`SimUart::device_receive`]) is for a device model such as [`super::tfmini::TfminiModel`].
//!
//! **Timing.** 8N1 framing: a byte is 10 bit times on the wire (start, 8 data, stop), so at
//! 115 200 baud 86.8 µs. Each direction is one wire: a byte starts when it is sent or when
//! the previous byte's stop bit ends, whichever is later, and is received when its stop bit
//! ends. [`SimUart::advance_to`] moves virtual time (the emulator calls it every
//! millisecond, after the device model has queued what it sends up to that time).
//!
//! **Receive buffer and overrun.** Received bytes wait in a buffer of `rx_capacity` bytes
//! (1 = the bare USART data register; a DMA ring buffer is larger). A byte that completes
//! while the buffer is full is lost and counted as an overrun (the STM32's ORE: the byte in
//! the shift register is dropped, the older ones are kept); the next `read` then reports
//! [`UartError::Overrun`] once, as embassy's UART reports it, and reads go on after it.
//!
//! **Faults.** [`SimUart::corrupt_rx`] flips one random bit of each received byte with a
//! given probability (seeded: the same seed corrupts the same bytes), counted.
//!
//! **Blocking.** `read` never waits: with nothing received it returns
//! [`UartError::WouldBlock`] (on the MCU it would block, and virtual time cannot pass inside a
//! call); callers poll with `read_ready` first. `write` queues the bytes at the current time
//! and returns at once; `flush` returns at once (the bytes still take their wire time).
//!
//! **Baud rates.** Each end has its own rate ([`SimUart::set_baud`] for the MCU's USART, as
//! embassy's `set_baudrate`; [`SimUart::set_device_baud`] for the device, e.g. a GNSS receiver
//! told to change its rate). A byte takes its sender's bit time on the wire. A receiver at
//! another rate samples the sender's waveform at its own bit centres (1.5, 2.5 … 8.5 of its bit
//! times after the start edge) and gets that byte instead, counted in
//! [`UartStats::baud_mismatched`]; e.g. 0x55 sent at 9600 reads 0x78 at 38400.
//!
//! Not modelled: parity, framing and noise errors as flags, the extra bytes a receiver faster
//! than its sender finds in one slow byte, flow control, break.

use std::collections::VecDeque;
use std::fmt;

use embedded_io::{ErrorKind, ErrorType, Read, ReadReady, Write};
use r2p_world::noise::Noise;

/// Bit times per 8N1 byte.
pub const BITS_PER_BYTE: u64 = 10;

/// A UART error seen by the MCU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UartError {
    /// Bytes were lost since the last read because the receive buffer was full.
    Overrun,
    /// Nothing received yet (the MCU would block here).
    WouldBlock,
}

impl fmt::Display for UartError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            UartError::Overrun => write!(f, "UART receive overrun: bytes were lost"),
            UartError::WouldBlock => {
                write!(f, "UART read with nothing received (check read_ready first)")
            }
        }
    }
}

impl std::error::Error for UartError {}

impl embedded_io::Error for UartError {
    fn kind(&self) -> ErrorKind {
        match self {
            UartError::Overrun => ErrorKind::Other,
            UartError::WouldBlock => ErrorKind::TimedOut,
        }
    }
}

/// One direction of the line: bytes in flight with the time their stop bit ends and the baud
/// rate they were sent at.
#[derive(Debug, Default)]
struct Wire {
    in_flight: VecDeque<(u64, u8, u32)>,
    free_at_ns: u64,
}

impl Wire {
    fn send(&mut self, at_ns: u64, baud: u32, bytes: &[u8]) {
        let byte_ns = byte_ns(baud);
        for &b in bytes {
            let start = self.free_at_ns.max(at_ns);
            self.free_at_ns = start + byte_ns;
            self.in_flight.push_back((self.free_at_ns, b, baud));
        }
    }

    /// Pops the next byte received by `now_ns`, as a receiver at `baud` reads it, and whether
    /// it was sent at another rate.
    fn arrived(&mut self, now_ns: u64, baud: u32) -> Option<(u8, bool)> {
        match self.in_flight.front() {
            Some(&(t, b, sent)) if t <= now_ns => {
                self.in_flight.pop_front();
                Some(if sent == baud { (b, false) } else { (resample(b, sent, baud), true) })
            }
            _ => None,
        }
    }
}

/// One 8N1 byte's time at `baud`, ns (10 bit times, rounded to the ns).
fn byte_ns(baud: u32) -> u64 {
    (BITS_PER_BYTE * 1_000_000_000 + u64::from(baud) / 2) / u64::from(baud)
}

/// The byte a receiver at `rx_baud` reads from `byte` sent at `tx_baud`: data bit j is the
/// line level at (j + 1.5) of its bit times after the start edge; the sender's frame is start
/// bit (low), data LSB first, then stop and idle (high).
pub fn resample(byte: u8, tx_baud: u32, rx_baud: u32) -> u8 {
    let mut out = 0u8;
    for j in 0..8u64 {
        // Position in sender bit times, in halves: (2j + 3) / 2 · tx / rx.
        let sender_bit = ((2 * j + 3) * u64::from(tx_baud)) / (2 * u64::from(rx_baud));
        let level = match sender_bit {
            0 => 0,
            1..=8 => (byte >> (sender_bit - 1)) & 1,
            _ => 1,
        };
        out |= level << j;
    }
    out
}

/// Counters of the line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UartStats {
    /// Bytes that reached the MCU's receive buffer.
    pub received: u64,
    /// Bytes lost to overrun.
    pub overruns: u64,
    /// Bytes corrupted on the way to the MCU (fault injection).
    pub corrupted: u64,
    /// Bytes the MCU sent that reached the device.
    pub delivered: u64,
    /// Bytes (either way) read at a baud rate other than the one they were sent at.
    pub baud_mismatched: u64,
}

/// The line and the MCU's UART.
#[derive(Debug)]
pub struct SimUart {
    baud: u32,
    device_baud: u32,
    now_ns: u64,
    to_mcu: Wire,
    to_device: Wire,
    rx: VecDeque<u8>,
    rx_capacity: usize,
    overrun_pending: bool,
    at_device: Vec<u8>,
    corrupt: Option<(f64, Noise)>,
    stats: UartStats,
}

impl SimUart {
    /// A line at `baud` (8N1) with a receive buffer of `rx_capacity` bytes (at least 1).
    pub fn new(baud: u32, rx_capacity: usize) -> Self {
        assert!(baud > 0, "baud rate 0");
        Self {
            baud,
            device_baud: baud,
            now_ns: 0,
            to_mcu: Wire::default(),
            to_device: Wire::default(),
            rx: VecDeque::new(),
            rx_capacity: rx_capacity.max(1),
            overrun_pending: false,
            at_device: Vec::new(),
            corrupt: None,
            stats: UartStats::default(),
        }
    }

    /// One byte's time on the wire at the MCU's rate, ns (10 bit times, rounded to the ns).
    pub fn byte_ns(&self) -> u64 {
        byte_ns(self.baud)
    }

    /// The MCU's baud rate.
    pub fn baud(&self) -> u32 {
        self.baud
    }

    /// The device's baud rate (the MCU's unless set).
    pub fn device_baud(&self) -> u32 {
        self.device_baud
    }

    /// The MCU reconfigures its USART to `baud` (bytes already on the wire keep theirs).
    pub fn set_baud(&mut self, baud: u32) {
        assert!(baud > 0, "baud rate 0");
        self.baud = baud;
    }

    /// The device changes its rate to `baud`.
    pub fn set_device_baud(&mut self, baud: u32) {
        assert!(baud > 0, "baud rate 0");
        self.device_baud = baud;
    }

    /// Virtual time of the line, ns.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// Counters so far.
    pub fn stats(&self) -> UartStats {
        self.stats
    }

    /// Bytes waiting in the receive buffer.
    pub fn rx_waiting(&self) -> usize {
        self.rx.len()
    }

    /// Flips one random bit of each byte to the MCU with probability `p`, drawn from
    /// stream `stream` of `seed`.
    pub fn corrupt_rx(&mut self, p: f64, seed: u64, stream: u64) {
        self.corrupt = Some((p, Noise::new(seed, stream)));
    }

    /// The device starts sending `bytes` at `at_ns` (or when the line is free).
    pub fn device_send_at(&mut self, at_ns: u64, bytes: &[u8]) {
        self.to_mcu.send(at_ns, self.device_baud, bytes);
    }

    /// When the line towards the MCU is free: the stop bit of the last byte queued, ns.
    pub fn device_free_at(&self) -> u64 {
        self.to_mcu.free_at_ns
    }

    /// Bytes from the MCU that have fully arrived at the device since the last call.
    pub fn device_receive(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.at_device)
    }

    /// Moves the line to `t_ns`: bytes whose stop bit has ended are received.
    pub fn advance_to(&mut self, t_ns: u64) {
        self.now_ns = self.now_ns.max(t_ns);
        while let Some((mut b, mismatched)) = self.to_mcu.arrived(self.now_ns, self.baud) {
            self.stats.baud_mismatched += u64::from(mismatched);
            if let Some((p, noise)) = &mut self.corrupt {
                if noise.uniform() < *p {
                    b ^= 1 << ((noise.uniform() * 8.0) as u32).min(7);
                    self.stats.corrupted += 1;
                }
            }
            if self.rx.len() < self.rx_capacity {
                self.rx.push_back(b);
                self.stats.received += 1;
            } else {
                self.stats.overruns += 1;
                self.overrun_pending = true;
            }
        }
        while let Some((b, mismatched)) = self.to_device.arrived(self.now_ns, self.device_baud) {
            self.stats.baud_mismatched += u64::from(mismatched);
            self.at_device.push(b);
            self.stats.delivered += 1;
        }
    }
}

impl ErrorType for SimUart {
    type Error = UartError;
}

impl ReadReady for SimUart {
    fn read_ready(&mut self) -> Result<bool, UartError> {
        Ok(!self.rx.is_empty() || self.overrun_pending)
    }
}

impl Read for SimUart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, UartError> {
        if buf.is_empty() {
            return Ok(0);
        }
        if std::mem::take(&mut self.overrun_pending) {
            return Err(UartError::Overrun);
        }
        if self.rx.is_empty() {
            return Err(UartError::WouldBlock);
        }
        let n = buf.len().min(self.rx.len());
        for (dst, src) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *dst = src;
        }
        Ok(n)
    }
}

impl Write for SimUart {
    fn write(&mut self, buf: &[u8]) -> Result<usize, UartError> {
        self.to_device.send(self.now_ns, self.baud, buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), UartError> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_take_ten_bit_times_back_to_back() {
        let mut u = SimUart::new(115_200, 64);
        assert_eq!(u.byte_ns(), 86_806); // 10/115200 s
        u.device_send_at(1_000, &[1, 2, 3]);
        u.advance_to(1_000 + 86_805);
        assert!(!u.read_ready().unwrap());
        u.advance_to(1_000 + 86_806);
        assert_eq!(u.rx_waiting(), 1);
        u.advance_to(1_000 + 3 * 86_806 - 1);
        assert_eq!(u.rx_waiting(), 2);
        u.advance_to(1_000 + 3 * 86_806);
        let mut b = [0; 8];
        assert_eq!(u.read(&mut b), Ok(3));
        assert_eq!(b[..3], [1, 2, 3]);
        assert_eq!(u.read(&mut b), Err(UartError::WouldBlock));
    }

    #[test]
    fn full_buffer_overruns_once_reported_then_reads_go_on() {
        let mut u = SimUart::new(115_200, 2);
        u.device_send_at(0, &[1, 2, 3, 4]);
        u.advance_to(1_000_000);
        assert_eq!(u.stats().overruns, 2);
        assert_eq!(u.stats().received, 2);
        let mut b = [0; 8];
        assert_eq!(u.read(&mut b), Err(UartError::Overrun));
        assert_eq!(u.read(&mut b), Ok(2));
        assert_eq!(b[..2], [1, 2], "the older bytes are kept, the new ones lost");
    }

    #[test]
    fn mcu_writes_reach_the_device_after_their_wire_time() {
        let mut u = SimUart::new(9_600, 1);
        u.advance_to(5_000);
        u.write_all(&[0x5A, 0x04]).unwrap();
        u.advance_to(5_000 + 2 * u.byte_ns() - 1);
        assert_eq!(u.device_receive(), [0x5A]);
        u.advance_to(5_000 + 2 * u.byte_ns());
        assert_eq!(u.device_receive(), [0x04]);
        assert_eq!(u.stats().delivered, 2);
    }

    #[test]
    fn a_byte_read_at_another_rate_is_resampled() {
        // 0x55 = start 0, then 1 0 1 0 1 0 1 0, stop 1. At 38400, a 9600 byte's bits are 4 bit
        // times long: samples 1.5, 2.5, 3.5 fall in its start bit (0), 4.5–7.5 in bit 0 (1),
        // 8.5 in bit 1 (0)... : 0b0111_1000.
        assert_eq!(resample(0x55, 9_600, 38_400), 0x78);
        // At 9600, a 38400 byte: samples at 6, 10, 14 … of its bit times: data bit 5 (0), then
        // stop and idle (1): 0xFE.
        assert_eq!(resample(0x55, 38_400, 9_600), 0xFE);
        assert_eq!(resample(0xA3, 9_600, 9_600), 0xA3);
        let mut u = SimUart::new(38_400, 64);
        u.set_device_baud(9_600);
        assert_eq!(u.device_baud(), 9_600);
        u.device_send_at(0, &[0x55, 0x62]);
        u.write_all(&[0xB5]).unwrap();
        u.advance_to(1_000_000_000);
        let mut b = [0; 4];
        assert_eq!(u.read(&mut b), Ok(2));
        assert_eq!(b[..2], [0x78, resample(0x62, 9_600, 38_400)]);
        assert_eq!(u.device_receive(), [resample(0xB5, 38_400, 9_600)]);
        assert_eq!(u.stats().baud_mismatched, 3);
        // Both at 9600: bytes pass, each 1.04 ms.
        u.set_baud(9_600);
        assert_eq!((u.baud(), u.byte_ns()), (9_600, 1_041_667));
        u.device_send_at(1_000_000_000, &[0x55]);
        assert_eq!(u.device_free_at(), 1_000_000_000 + 1_041_667);
        u.advance_to(2_000_000_000);
        assert_eq!((u.read(&mut b), b[0]), (Ok(1), 0x55));
        assert_eq!(u.stats().baud_mismatched, 3);
    }

    #[test]
    fn corruption_is_seeded_and_counted() {
        let run = |seed| {
            let mut u = SimUart::new(115_200, 4096);
            u.corrupt_rx(0.1, seed, 0);
            u.device_send_at(0, &[0u8; 1000]);
            u.advance_to(1_000_000_000);
            let mut b = vec![0; 1000];
            assert_eq!(u.read(&mut b), Ok(1000));
            let flipped = b.iter().filter(|&&x| x != 0).count() as u64;
            assert_eq!(flipped, u.stats().corrupted);
            assert!(b.iter().all(|x| x.count_ones() <= 1), "one bit per byte");
            b
        };
        let (a, c) = (run(1), run(2));
        assert_eq!(a, run(1));
        assert_ne!(a, c);
        let n = a.iter().filter(|&&x| x != 0).count();
        // Binomial(1000, 0.1): 100 ± 9.5; 5σ.
        assert!((52..=148).contains(&n), "{n}");
    }
}
