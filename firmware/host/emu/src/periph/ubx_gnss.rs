//! Model of a u-blox GNSS receiver on a [`SimUart`] (issue 21): UBX-NAV-PVT navigation
//! solutions at its navigation rate, from the world's [`GnssReceiver`].
//!
//! **UBX framing** (u-blox 8 / M8 receiver description, UBX-13003221, "UBX Protocol"): sync
//! characters 0xB5 0x62, class, id, a little-endian 16-bit payload length, the payload and an
//! 8-bit Fletcher checksum (CK_A, CK_B) over class, id, length and payload. **NAV-PVT** (class
//! 0x01, id 0x07) has a 92-byte payload: iTOW (ms of the GPS week), UTC date and time with
//! their validity flags, the fix type (0 none, 3 3-D), flags (bit 0 gnssFixOK), the number of
//! satellites, longitude and latitude in 1e-7 degrees, heights above the ellipsoid and mean sea
//! level in mm, horizontal and vertical accuracy in mm, the NED velocity and ground speed in
//! mm/s, heading of motion in 1e-5 degrees, speed and heading accuracy, position DOP in 0.01.
//! The layout is checked by an independent decoder, the `ublox` crate (a dev-dependency).
//!
//! Timing: an epoch due at t is put on the wire at t (the UART paces its bytes: 100 bytes at
//! 9600 baud take 104 ms), when [`UbxGnssModel::update`] runs before the line passes t. The
//! receiver's time pulse (PPS) marks the top of each UTC second ([`UbxGnssModel::pps_at`]).
//!
//! Not modelled: NMEA output (the receiver here is configured for UBX only, as a module would
//! configure it), configuration messages (CFG-RATE, CFG-PRT), other UBX messages.

use r2p_world::gnss::{FixType, GnssFix, GnssReceiver};

use super::uart::SimUart;

const NS_PER_S: u64 = 1_000_000_000;
/// NAV-PVT's payload length.
pub const NAV_PVT_LEN: usize = 92;
/// A whole NAV-PVT frame: sync, class, id, length, payload, checksum.
pub const NAV_PVT_FRAME_LEN: usize = NAV_PVT_LEN + 8;
/// The geoid's height above the ellipsoid used for heights above mean sea level, m (the
/// receiver's own model gives it; this one is a constant).
const GEOID_SEPARATION_M: f64 = 47.0;

/// A UTC date and time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Utc {
    /// Year.
    pub year: u16,
    /// Month, 1–12.
    pub month: u8,
    /// Day, 1–31.
    pub day: u8,
    /// Hour.
    pub hour: u8,
    /// Minute.
    pub min: u8,
    /// Second.
    pub sec: u8,
}

impl Utc {
    /// The date and time `unix_s` seconds after 1970-01-01 00:00:00 UTC (no leap seconds, as
    /// UTC fields have none between them; H. Hinnant's `civil_from_days`).
    pub fn from_unix(unix_s: u64) -> Utc {
        let (days, secs) = ((unix_s / 86_400) as i64, unix_s % 86_400);
        let z = days + 719_468;
        let era = z.div_euclid(146_097);
        let doe = z - era * 146_097;
        let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
        let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
        let mp = (5 * doy + 2) / 153;
        let day = (doy - (153 * mp + 2) / 5 + 1) as u8;
        let month = if mp < 10 { mp + 3 } else { mp - 9 } as u8;
        let year = (yoe + era * 400 + i64::from(month <= 2)) as u16;
        Utc {
            year,
            month,
            day,
            hour: (secs / 3600) as u8,
            min: (secs / 60 % 60) as u8,
            sec: (secs % 60) as u8,
        }
    }
}

/// One navigation epoch as NAV-PVT reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PvtEpoch {
    /// GPS time of week, ms.
    pub itow_ms: u32,
    /// UTC.
    pub utc: Utc,
    /// The solution.
    pub fix: GnssFix,
    /// Velocity east, north, up, m/s.
    pub velocity_enu: [f64; 3],
}

/// The 8-bit Fletcher checksum UBX uses, over `bytes`.
pub fn checksum(bytes: &[u8]) -> [u8; 2] {
    let (mut a, mut b) = (0u8, 0u8);
    for &x in bytes {
        a = a.wrapping_add(x);
        b = b.wrapping_add(a);
    }
    [a, b]
}

/// `e` as a UBX-NAV-PVT frame.
pub fn nav_pvt(e: &PvtEpoch) -> [u8; NAV_PVT_FRAME_LEN] {
    let mut p = [0u8; NAV_PVT_LEN];
    let mm = |m: f64| (m * 1000.0).round() as i32;
    let acc = |m: f64| if m.is_finite() { (m * 1000.0).round() as u32 } else { u32::MAX };
    let fixed = e.fix.fix == FixType::Fix3d;
    let [ve, vn, vu] = e.velocity_enu;
    let put = |p: &mut [u8], at: usize, b: &[u8]| p[at..at + b.len()].copy_from_slice(b);
    put(&mut p, 0, &e.itow_ms.to_le_bytes());
    put(&mut p, 4, &e.utc.year.to_le_bytes());
    put(&mut p, 6, &[e.utc.month, e.utc.day, e.utc.hour, e.utc.min, e.utc.sec]);
    // valid: validDate, validTime, fullyResolved once the receiver has its fix.
    p[11] = if fixed { 0x07 } else { 0x00 };
    put(&mut p, 12, &(if fixed { 30u32 } else { u32::MAX }).to_le_bytes()); // tAcc, ns
    p[20] = if fixed { 3 } else { 0 };
    p[21] = u8::from(fixed); // gnssFixOK
    p[23] = e.fix.satellites;
    put(&mut p, 24, &((e.fix.position.lon_deg * 1e7).round() as i32).to_le_bytes());
    put(&mut p, 28, &((e.fix.position.lat_deg * 1e7).round() as i32).to_le_bytes());
    put(&mut p, 32, &mm(e.fix.position.height_m).to_le_bytes());
    put(&mut p, 36, &mm(e.fix.position.height_m - GEOID_SEPARATION_M).to_le_bytes());
    put(&mut p, 40, &acc(e.fix.h_acc_m).to_le_bytes());
    put(&mut p, 44, &acc(e.fix.v_acc_m).to_le_bytes());
    put(&mut p, 48, &mm(vn).to_le_bytes());
    put(&mut p, 52, &mm(ve).to_le_bytes());
    put(&mut p, 56, &mm(-vu).to_le_bytes());
    put(&mut p, 60, &mm(ve.hypot(vn)).to_le_bytes());
    let heading = ve.atan2(vn).to_degrees().rem_euclid(360.0);
    put(&mut p, 64, &((heading * 1e5).round() as i32).to_le_bytes());
    put(&mut p, 68, &500u32.to_le_bytes()); // sAcc, mm/s
    put(&mut p, 72, &(180u32 * 100_000).to_le_bytes()); // headAcc: unknown
    put(&mut p, 76, &(if fixed { 120u16 } else { 9999 }).to_le_bytes()); // pDOP 1.20
    let mut f = [0u8; NAV_PVT_FRAME_LEN];
    f[..6].copy_from_slice(&[0xB5, 0x62, 0x01, 0x07, NAV_PVT_LEN as u8, 0]);
    f[6..6 + NAV_PVT_LEN].copy_from_slice(&p);
    let ck = checksum(&f[2..6 + NAV_PVT_LEN]);
    f[6 + NAV_PVT_LEN..].copy_from_slice(&ck);
    f
}

/// The receiver's state on its UART.
#[derive(Clone, Debug)]
pub struct UbxGnssModel {
    receiver: GnssReceiver,
    rate_hz: u32,
    next_ns: u64,
    /// UTC at power-up (t = 0), s since 1970, and the GPS time of week then, ms.
    start_unix_s: u64,
    start_tow_ms: u32,
    epochs: u64,
}

impl UbxGnssModel {
    /// A receiver powered up at t = 0, when UTC was `start_unix_s` (a whole second) and the GPS
    /// time of week `start_tow_ms`, sending NAV-PVT at `rate_hz` (1–10 Hz) on the top of its
    /// seconds' fractions.
    pub fn new(receiver: GnssReceiver, rate_hz: u32, start_unix_s: u64, start_tow_ms: u32) -> Self {
        let rate_hz = rate_hz.clamp(1, 10);
        Self {
            receiver,
            rate_hz,
            next_ns: NS_PER_S / u64::from(rate_hz),
            start_unix_s,
            start_tow_ms,
            epochs: 0,
        }
    }

    /// Epochs sent so far.
    pub fn epochs(&self) -> u64 {
        self.epochs
    }

    /// The time pulse's rising edge at or after `t_ns` (the top of each UTC second), ns.
    pub fn pps_at(&self, t_ns: u64) -> u64 {
        t_ns.div_ceil(NS_PER_S) * NS_PER_S
    }

    /// Sends the epochs due by `now_ns`, the antenna at `antenna_enu` metres from the world's
    /// origin moving at `velocity_enu` m/s.
    pub fn update(
        &mut self,
        now_ns: u64,
        uart: &mut SimUart,
        antenna_enu: [f64; 3],
        velocity_enu: [f64; 3],
    ) {
        uart.device_receive(); // configuration is not modelled: bytes sent to it are dropped
        while self.next_ns <= now_ns {
            let t_ms = self.next_ns / 1_000_000;
            let fix = self.receiver.solve(self.next_ns as f64 / NS_PER_S as f64, antenna_enu);
            let epoch = PvtEpoch {
                itow_ms: ((u64::from(self.start_tow_ms) + t_ms) % 604_800_000) as u32,
                utc: Utc::from_unix(self.start_unix_s + t_ms / 1000),
                fix,
                velocity_enu,
            };
            uart.device_send_at(self.next_ns, &nav_pvt(&epoch));
            self.epochs += 1;
            self.next_ns += NS_PER_S / u64::from(self.rate_hz);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_io::Read;
    use r2p_world::gnss::{Geodetic, GnssParams};
    use ublox::proto23::{PacketRef, Proto23};
    use ublox::{GnssFixType, Parser, UbxPacket};

    const ORIGIN: Geodetic = Geodetic { lat_deg: 45.478, lon_deg: 9.227, height_m: 170.0 };
    /// 2026-11-27 12:00:00 UTC.
    const NOON: u64 = 1_795_780_800;

    #[test]
    fn utc_from_unix_seconds() {
        assert_eq!(
            Utc::from_unix(0),
            Utc { year: 1970, month: 1, day: 1, hour: 0, min: 0, sec: 0 }
        );
        assert_eq!(
            Utc::from_unix(NOON),
            Utc { year: 2026, month: 11, day: 27, hour: 12, min: 0, sec: 0 }
        );
        // A leap day.
        assert_eq!(
            Utc::from_unix(951_782_400 + 3661),
            Utc { year: 2000, month: 2, day: 29, hour: 1, min: 1, sec: 1 }
        );
        // Against Python's datetime (an independent implementation): ends of days, leap years
        // 2000 and 2024, the non-leap 2100, 2038's 32-bit limit.
        let cases = [
            (946_688_399, (2000, 1, 1, 0, 59, 59)),
            (1_709_251_199, (2024, 2, 29, 23, 59, 59)),
            (4_102_447_025, (2100, 1, 1, 0, 37, 5)),
            (1_234_567_890, (2009, 2, 13, 23, 31, 30)),
            (2_147_483_647, (2038, 1, 19, 3, 14, 7)),
            (4_107_542_400, (2100, 3, 1, 0, 0, 0)),
        ];
        for (unix, (year, month, day, hour, min, sec)) in cases {
            assert_eq!(Utc::from_unix(unix), Utc { year, month, day, hour, min, sec }, "{unix}");
        }
    }

    #[test]
    fn the_ublox_crate_decodes_our_nav_pvt_over_the_uart() {
        let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, 5, 0);
        let mut gnss = UbxGnssModel::new(rx, 5, NOON, 475_218_000);
        let mut uart = SimUart::new(115_200, 4096);
        let mut parser = Parser::<_, Proto23>::new(Vec::new());
        let mut seen = Vec::new();
        for ms in (0..30_000u64).step_by(10) {
            let t = ms * 1_000_000;
            gnss.update(t, &mut uart, [12.0, -3.0, 0.5], [0.3, 0.4, 0.0]);
            uart.advance_to(t);
            let mut buf = [0u8; 256];
            let n = uart.read(&mut buf).unwrap_or(0);
            let mut it = parser.consume_ubx(&buf[..n]);
            while let Some(p) = it.next() {
                if let Ok(UbxPacket::Proto23(PacketRef::NavPvt(pvt))) = p {
                    seen.push((
                        pvt.itow(),
                        pvt.fix_type(),
                        pvt.num_satellites(),
                        pvt.latitude(),
                        pvt.longitude(),
                        pvt.height_above_ellipsoid(),
                        pvt.ground_speed_2d(),
                        pvt.heading_motion(),
                        pvt.sec(),
                        pvt.horizontal_accuracy(),
                        pvt.vertical_accuracy(),
                    ));
                }
            }
        }
        // 5 Hz for 30 s, the last epoch's bytes still on the wire.
        assert!((148..=150).contains(&seen.len()), "{} epochs", seen.len());
        let early = seen[0];
        assert_eq!((early.0, early.1, early.2), (475_218_200, GnssFixType::NoFix, 0));
        let last = *seen.last().unwrap();
        assert_eq!((last.1, last.2), (GnssFixType::Fix3D, 12));
        let back = ORIGIN.enu_to(&Geodetic { lat_deg: last.3, lon_deg: last.4, height_m: last.5 });
        assert!((back[0] - 12.0).abs() < 5.0 && (back[1] + 3.0).abs() < 5.0, "{back:?}");
        assert!((last.6 - 0.5).abs() < 1e-3 && (last.7 - 36.8699).abs() < 1e-3, "{last:?}");
        assert_eq!(last.8, 29, "UTC second of the epoch at 29.8 s");
        // Accuracy: unknown (u32::MAX mm) before the fix, the receiver's σ after it.
        assert_eq!((early.9, early.10), (f64::from(u32::MAX) / 1e3, f64::from(u32::MAX) / 1e3));
        assert_eq!((last.9, last.10), (1.0, 2.0));
        // One epoch each 0.2 s up to 29.8 s: 149 sent (the parser saw them all but any still
        // on the wire).
        assert_eq!(gnss.epochs(), 149);
    }

    #[test]
    fn a_corrupted_frame_fails_its_checksum_in_the_ublox_parser() {
        let e = PvtEpoch {
            itow_ms: 1,
            utc: Utc::from_unix(NOON),
            fix: GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, 1, 0).solve(0.0, [0.0; 3]),
            velocity_enu: [0.0; 3],
        };
        let mut f = nav_pvt(&e);
        let mut parser = Parser::<_, Proto23>::new(Vec::new());
        assert!(matches!(
            parser.consume_ubx(&f).next(),
            Some(Ok(UbxPacket::Proto23(PacketRef::NavPvt(_))))
        ));
        f[30] ^= 1;
        let mut parser = Parser::<_, Proto23>::new(Vec::new());
        assert!(matches!(parser.consume_ubx(&f).next(), Some(Err(_))));
    }

    #[test]
    fn the_time_pulse_marks_each_second() {
        let gnss =
            UbxGnssModel::new(GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, 1, 0), 1, NOON, 0);
        assert_eq!(gnss.pps_at(1), NS_PER_S);
        assert_eq!(gnss.pps_at(2 * NS_PER_S), 2 * NS_PER_S);
    }
}
