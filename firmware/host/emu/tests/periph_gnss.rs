//! The UBX decoder and boot configuration (r2p-drivers `ubx`) against the emulator's paced UART
//! and u-blox receiver model (M8 and M10, from their factory settings), fed by the world's GNSS
//! model; every NAV-PVT cross-checked against the `ublox` crate decoding the same bytes.

use embedded_io::{Read, Write};
use r2p_drivers::ubx::{self, Decoder, Message, NavPvt};
use r2p_emu::periph::uart::{SimUart, UartError};
use r2p_emu::periph::ubx_gnss::{Generation, UbxGnssModel};
use r2p_world::gnss::{Geodetic, GnssParams, GnssReceiver};
use ublox::proto23::{PacketRef, Proto23};
use ublox::{Parser, UbxPacket};

const ORIGIN: Geodetic = Geodetic { lat_deg: 45.478, lon_deg: 9.227, height_m: 170.0 };
/// 2026-11-27 12:00:00 UTC and the GPS time of week then.
const NOON: u64 = 1_795_780_800;
const TOW_MS: u32 = 475_218_000;
const ANTENNA: [f64; 3] = [12.0, -3.0, 0.5];
const VELOCITY: [f64; 3] = [0.3, 0.4, 0.0];

/// The MCU's UART with the decoder, the receiver model, and everything the MCU read.
struct Rig {
    uart: SimUart,
    gnss: UbxGnssModel,
    dec: Decoder,
    t_ms: u64,
    messages: Vec<(u64, Message)>,
    /// Bytes read at the operating baud rate, for the `ublox` crate.
    raw: Vec<u8>,
    overruns: u32,
}

impl Rig {
    fn new(gnss: UbxGnssModel, mcu_baud: u32) -> Self {
        Rig {
            uart: SimUart::new(mcu_baud, 512),
            gnss,
            dec: Decoder::new(),
            t_ms: 0,
            messages: Vec::new(),
            raw: Vec::new(),
            overruns: 0,
        }
    }

    fn factory(generation: Generation, seed: u64) -> Self {
        let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, 47.0, seed, 0);
        Rig::new(UbxGnssModel::factory(rx, generation, NOON, TOW_MS), ubx::OPERATING_BAUD)
    }

    /// Runs `ms` milliseconds, reading everything the UART has each millisecond.
    fn run(&mut self, ms: u64) {
        for _ in 0..ms {
            self.t_ms += 1;
            let t = self.t_ms * 1_000_000;
            self.gnss.update(t, &mut self.uart, ANTENNA, VELOCITY);
            self.uart.advance_to(t);
            let mut buf = [0u8; 512];
            match self.uart.read(&mut buf) {
                Ok(n) => {
                    if self.uart.baud() == ubx::OPERATING_BAUD {
                        self.raw.extend(&buf[..n]);
                    }
                    for &b in &buf[..n] {
                        if let Some(m) = self.dec.push(b) {
                            self.messages.push((self.t_ms, m));
                        }
                    }
                }
                Err(UartError::WouldBlock) => {}
                Err(UartError::Overrun) => self.overruns += 1,
            }
        }
    }

    /// What the module does at boot (r2p_drivers::ubx's documentation): the configuration at
    /// each rate of BOOT_BAUDS, then listen at the operating rate.
    fn boot(&mut self, rate_hz: u8) {
        let mut cfg = [0u8; ubx::BOOT_CONFIG_LEN];
        ubx::boot_config(rate_hz, &mut cfg).unwrap();
        for baud in ubx::BOOT_BAUDS {
            self.uart.set_baud(baud);
            self.uart.write_all(&cfg).unwrap();
            self.run(300);
        }
        self.uart.set_baud(ubx::OPERATING_BAUD);
    }

    fn pvts(&self) -> Vec<(u64, NavPvt)> {
        let pvt = |&(t, m): &(u64, Message)| match m {
            Message::NavPvt(p) => Some((t, p)),
            _ => None,
        };
        self.messages.iter().filter_map(pvt).collect()
    }

    fn acks(&self) -> Vec<Message> {
        let ack = |m: &Message| matches!(m, Message::Ack(..) | Message::Nak(..));
        self.messages.iter().map(|&(_, m)| m).filter(ack).collect()
    }
}

/// Every NAV-PVT the `ublox` crate finds in `bytes`, as our decoder's fields.
fn ublox_crate_pvts(bytes: &[u8]) -> Vec<[i64; 14]> {
    let mut parser = Parser::<_, Proto23>::new(Vec::new());
    let mut it = parser.consume_ubx(bytes);
    let mut out = Vec::new();
    while let Some(p) = it.next() {
        if let Ok(UbxPacket::Proto23(PacketRef::NavPvt(p))) = p {
            out.push([
                i64::from(p.itow()),
                i64::from(p.year()),
                i64::from(p.sec()),
                p.fix_type() as i64,
                i64::from(p.num_satellites()),
                (p.longitude() * 1e7).round() as i64,
                (p.latitude() * 1e7).round() as i64,
                (p.height_above_ellipsoid() * 1e3).round() as i64,
                (p.horizontal_accuracy() * 1e3).round() as i64,
                (p.vertical_accuracy() * 1e3).round() as i64,
                (p.vel_north() * 1e3).round() as i64,
                (p.vel_east() * 1e3).round() as i64,
                (p.ground_speed_2d() * 1e3).round() as i64,
                (p.heading_motion() * 1e5).round() as i64,
            ]);
        }
    }
    out
}

fn ours(p: &NavPvt) -> [i64; 14] {
    [
        i64::from(p.itow_ms),
        i64::from(p.year),
        i64::from(p.sec),
        i64::from(p.fix_type),
        i64::from(p.num_sv),
        i64::from(p.lon_e7),
        i64::from(p.lat_e7),
        i64::from(p.height_mm),
        i64::from(p.h_acc_mm),
        i64::from(p.v_acc_mm),
        i64::from(p.vel_n_mm_s),
        i64::from(p.vel_e_mm_s),
        i64::from(p.g_speed_mm_s),
        i64::from(p.head_mot_e5),
    ]
}

#[test]
fn an_m8_at_its_factory_9600_baud_is_moved_to_38400_and_nav_pvt_at_5_hz() {
    let mut rig = Rig::factory(Generation::M8, 1);
    // Before configuration: NMEA at 9600, which the MCU at 38400 cannot read.
    rig.run(2_000);
    assert_eq!(rig.gnss.baud(), Some(9_600));
    assert_eq!(rig.gnss.output(), (true, false));
    assert!(rig.messages.is_empty());
    assert!(rig.dec.stats().dropped_bytes > 0, "the NMEA read at the wrong rate is noise");
    assert!(rig.uart.stats().baud_mismatched > 0);
    rig.boot(5);
    // At 38400 the M8 heard noise; at 9600 it NAKs CFG-VALSET, ACKs CFG-MSG, CFG-RATE and
    // CFG-PRT, the last at 9600 before it switches (the MCU, still at 9600, reads them all).
    assert_eq!(
        rig.acks(),
        [
            Message::Nak(0x06, 0x8A),
            Message::Ack(0x06, 0x01),
            Message::Ack(0x06, 0x08),
            Message::Ack(0x06, 0x00)
        ]
    );
    assert_eq!(rig.gnss.acks_naks(), (3, 1));
    assert_eq!(rig.gnss.baud(), Some(38_400));
    assert_eq!(rig.gnss.output(), (false, true));
    assert_eq!(rig.gnss.rate_hz(), 5.0);
    let before = rig.pvts().len();
    rig.run(30_000);
    let pvts = rig.pvts();
    // 5 Hz for 30 s (the epoch at the end may be on the wire).
    let times: Vec<_> = pvts.iter().map(|(t, p)| (*t, p.itow_ms - TOW_MS)).collect();
    assert!(
        (149..=150).contains(&(pvts.len() - before)),
        "{} {before} {times:?}",
        pvts.len() - before
    );
    let d = rig.dec.stats();
    assert_eq!((d.checksum_errors, d.length_errors), (0, 0));
    // Consecutive epochs 200 ms apart in GPS time; a 3-D fix after the time to first fix.
    let late: Vec<_> = pvts[before..].iter().map(|&(_, p)| p).collect();
    assert!(late.windows(2).all(|w| w[1].itow_ms == w[0].itow_ms + 200));
    let last = late.last().unwrap();
    assert_eq!((last.fix_type, last.gnss_fix_ok(), last.num_sv), (3, true, 12));
    let back = ORIGIN.enu_to(&Geodetic {
        lat_deg: f64::from(last.lat_e7) * 1e-7,
        lon_deg: f64::from(last.lon_e7) * 1e-7,
        height_m: f64::from(last.height_mm) * 1e-3,
    });
    let tol = 5.0 * GnssParams::UBLOX_M8.sigma_h_m; // 5 σ of the receiver's error
    assert!((back[0] - 12.0).abs() < tol && (back[1] + 3.0).abs() < tol, "{back:?}");
    assert_eq!((last.vel_n_mm_s, last.vel_e_mm_s, last.g_speed_mm_s), (400, 300, 500));
    assert_eq!((last.year, last.month, last.day, last.valid), (2026, 11, 27, 7));
    // The same frames, field by field, through the ublox crate.
    let theirs = ublox_crate_pvts(&rig.raw);
    let mine: Vec<_> = pvts.iter().map(|(_, p)| ours(p)).collect();
    assert_eq!(theirs, mine);
    assert_eq!(rig.overruns, 0);
}

#[test]
fn an_m10_at_38400_takes_the_valset_and_naks_the_legacy_messages() {
    let mut rig = Rig::factory(Generation::M10, 2);
    rig.run(1_500);
    // NMEA at 38400 reaches the MCU (and is skipped): no UBX yet.
    assert!(rig.messages.is_empty());
    assert!(rig.dec.stats().dropped_bytes > 100, "{:?}", rig.dec.stats());
    assert_eq!(rig.uart.stats().baud_mismatched, 0);
    rig.boot(10);
    assert_eq!(
        rig.acks(),
        [
            Message::Ack(0x06, 0x8A),
            Message::Nak(0x06, 0x01),
            Message::Nak(0x06, 0x08),
            Message::Nak(0x06, 0x00)
        ]
    );
    assert_eq!(rig.gnss.baud(), Some(38_400), "an M10 never changes its rate");
    assert_eq!((rig.gnss.output(), rig.gnss.rate_hz()), ((false, true), 10.0));
    let before = rig.pvts().len();
    rig.run(10_000);
    let n = rig.pvts().len() - before;
    assert!((99..=100).contains(&n), "{n}");
    let theirs = ublox_crate_pvts(&rig.raw);
    let mine: Vec<_> = rig.pvts().iter().map(|(_, p)| ours(p)).collect();
    assert_eq!(theirs, mine);
}

#[test]
fn an_m8_configured_before_a_module_reset_answers_at_38400() {
    let mut rig = Rig::factory(Generation::M8, 3);
    rig.boot(5);
    rig.run(1_000);
    // The module resets; the receiver keeps power and its configuration.
    rig.dec = Decoder::new();
    rig.messages.clear();
    rig.boot(2);
    assert_eq!(
        rig.acks(),
        [
            Message::Nak(0x06, 0x8A),
            Message::Ack(0x06, 0x01),
            Message::Ack(0x06, 0x08),
            Message::Ack(0x06, 0x00)
        ]
    );
    assert_eq!((rig.gnss.baud(), rig.gnss.rate_hz()), (Some(38_400), 2.0));
}

#[test]
fn corrupted_bytes_are_counted_and_never_decoded_as_a_wrong_frame() {
    let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, 47.0, 4, 0);
    let mut rig = Rig::new(UbxGnssModel::new(rx, 10, NOON, TOW_MS), ubx::OPERATING_BAUD);
    rig.uart.corrupt_rx(0.002, 9, 1);
    rig.run(60_000);
    let d = rig.dec.stats();
    // 600 frames of 100 bytes at p = 0.002 per byte: 1 − 0.998^100 = 18 % hit, ~109 ± 10.
    assert!((60..=160).contains(&d.checksum_errors), "{d:?}");
    assert!(rig.uart.stats().corrupted > 0);
    let pvts = rig.pvts();
    assert_eq!(pvts.len() as u32 + d.checksum_errors + d.length_errors, 600 - 1);
    // Every frame decoded is one the receiver sent: its GPS time on the 100 ms grid, and the
    // ublox crate agrees on every frame.
    assert!(pvts.iter().all(|(_, p)| (p.itow_ms - TOW_MS).is_multiple_of(100)));
    let mine: Vec<_> = pvts.iter().map(|(_, p)| ours(p)).collect();
    assert_eq!(ublox_crate_pvts(&rig.raw), mine);
}

#[test]
fn invalid_configuration_is_nakked_and_not_applied() {
    let mut rig = Rig::factory(Generation::M10, 5);
    let mut f = [0u8; 64];
    // A measurement period of 10 ms (under 25), and an unknown key beside a good one.
    let n = ubx::cfg_valset(1, &[(ubx::KEY_RATE_MEAS, 10)], &mut f).unwrap();
    rig.uart.write_all(&f[..n]).unwrap();
    rig.run(100);
    let items = [(ubx::KEY_UART1OUTPROT_NMEA, 0), (0x1099_0001, 1)];
    let n = ubx::cfg_valset(1, &items, &mut f).unwrap();
    rig.uart.write_all(&f[..n]).unwrap();
    // No layer to write to.
    let n = ubx::cfg_valset(0, &[(ubx::KEY_UART1OUTPROT_NMEA, 0)], &mut f).unwrap();
    rig.uart.write_all(&f[..n]).unwrap();
    rig.run(200);
    assert_eq!(rig.acks(), [Message::Nak(6, 0x8A); 3]);
    assert_eq!((rig.gnss.output(), rig.gnss.rate_hz()), ((true, false), 1.0));
}
