//! The external GNSS receiver (u-blox class, on USART1 with its time pulse on TIM3_CH4): the
//! link's set-up, the epochs it sends, and what the module publishes of them (`imu/gnss`,
//! [`GnssFix`]) with UTC disciplined by the time pulse.
//!
//! **The link** ([`Link`]): at boot, and again whenever no NAV-PVT has come for
//! [`RECONFIGURE_US`], the module sends `r2p_drivers::ubx::boot_config` at each rate of
//! `ubx::BOOT_BAUDS` (an M9/M10 listens at 38 400 baud, an M8 at 9 600 from the factory; why,
//! in that module's documentation), each after the previous one has left the wire, then
//! listens at `ubx::OPERATING_BAUD`. Sans-IO: [`Link::poll`] says what to do on the UART now
//! ([`Action`]); both board-support layers do it.
//!
//! **Time** ([`Gnss`]): the time pulse's rising edge marks the top of a UTC second on the
//! module's own clock (an input capture: the timer latches the count, no interrupt latency).
//! A NAV-PVT with a valid, fully resolved UTC arrives some tens of ms after its epoch; the
//! epoch's UTC minus the time since the last edge is the edge's second, minus that latency,
//! so rounding to the nearest second names the edge (the latency must stay under 0.5 s: a
//! 100-byte frame takes 26 ms at 38 400 baud). From then on UTC is the edge's second plus the
//! module's time since the edge — to the capture's microsecond and the crystal's drift over a
//! second (±50 ppm: ±50 µs), refreshed every second. Without a pulse (not wired, no fix) UTC is
//! the last epoch's plus the time since it arrived: late by the frame's latency (`pps` false).

use r2p_drivers::ubx::{self, NavPvt};
use r2p_msgs::GnssFix;

/// A receiver silent this long (no NAV-PVT) is configured again, µs.
pub const RECONFIGURE_US: u64 = 3_000_000;
/// A time pulse older than this no longer disciplines UTC, µs (edges come every second).
pub const PPS_VALID_US: u64 = 1_500_000;

/// What the board-support layer does on the receiver's UART.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Set the UART to `baud` and send [`Link::config`]'s bytes.
    Send {
        /// Baud rate, 8N1.
        baud: u32,
    },
    /// Set the UART to `baud` and receive.
    Listen {
        /// Baud rate, 8N1.
        baud: u32,
    },
}

/// The link's set-up state (see the module documentation).
#[derive(Clone, Debug)]
pub struct Link {
    decoder: ubx::Decoder,
    config: [u8; ubx::BOOT_CONFIG_LEN],
    /// Next configuration step: an index into `BOOT_BAUDS`, then `BOOT_BAUDS.len()` = listen.
    step: usize,
    /// When the next step is due, µs.
    next_us: u64,
    /// The last NAV-PVT, µs.
    last_epoch_us: Option<u64>,
}

impl Link {
    /// A link that configures the receiver for NAV-PVT at `rate_hz` (1–10, clamped).
    pub fn new(rate_hz: u32) -> Self {
        let mut config = [0; ubx::BOOT_CONFIG_LEN];
        // 1–10 Hz after the clamp: boot_config cannot refuse it.
        let _ = ubx::boot_config(rate_hz.clamp(1, 10) as u8, &mut config);
        Self { decoder: ubx::Decoder::new(), config, step: 0, next_us: 0, last_epoch_us: None }
    }

    /// The configuration bytes an [`Action::Send`] sends.
    pub fn config(&self) -> &[u8] {
        &self.config
    }

    /// What to do on the UART at `now_us`, if anything.
    pub fn poll(&mut self, now_us: u64) -> Option<Action> {
        let silent_since = self.last_epoch_us.unwrap_or(0).max(self.next_us);
        if self.step > ubx::BOOT_BAUDS.len() && now_us >= silent_since + RECONFIGURE_US {
            self.step = 0; // silent: configure again
        }
        if self.step > ubx::BOOT_BAUDS.len() || now_us < self.next_us {
            return None;
        }
        let action = match ubx::BOOT_BAUDS.get(self.step) {
            Some(&baud) => {
                // The next step once these bytes have left the wire (10 bits a byte) and 5 ms.
                let bits = 10 * ubx::BOOT_CONFIG_LEN as u64;
                self.next_us = now_us + bits * 1_000_000 / u64::from(baud) + 5_000;
                Action::Send { baud }
            }
            None => {
                self.next_us = now_us;
                Action::Listen { baud: ubx::OPERATING_BAUD }
            }
        };
        self.step += 1;
        Some(action)
    }

    /// Bytes received at `now_us`: the last NAV-PVT among them, if any.
    pub fn receive(&mut self, now_us: u64, bytes: &[u8]) -> Option<NavPvt> {
        let mut last = None;
        for &b in bytes {
            if let Some(ubx::Message::NavPvt(p)) = self.decoder.push(b) {
                last = Some(p);
                self.last_epoch_us = Some(now_us);
            }
        }
        last
    }

    /// The decoder's counters (malformed frames, bytes skipped).
    pub fn stats(&self) -> ubx::Stats {
        self.decoder.stats()
    }
}

/// Unix time of a UTC date and time, seconds (days from the civil calendar: Howard Hinnant's
/// `days_from_civil`, exact for the proleptic Gregorian calendar).
pub fn unix_seconds(year: u16, month: u8, day: u8, hour: u8, min: u8, sec: u8) -> i64 {
    let y = i64::from(year) - i64::from(month <= 2);
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let m = i64::from(month);
    let doy = (153 * (m + if m > 2 { -3 } else { 9 }) + 2) / 5 + i64::from(day) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    days * 86_400 + i64::from(hour) * 3600 + i64::from(min) * 60 + i64::from(sec)
}

/// The receiver as the module publishes it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Gnss {
    fix: GnssFix,
    /// The last epoch: its arrival (µs) and its UTC (µs since 1970), if valid.
    epoch: Option<(u64, Option<i64>)>,
    /// The last time pulse edge (µs) and, once named, its UTC second (µs since 1970).
    pps: Option<(u64, Option<i64>)>,
}

impl Gnss {
    /// A time pulse's rising edge at `edge_us` (the capture's time on the module's clock).
    pub fn take_pps(&mut self, edge_us: u64) {
        // The second it marks is named by the next epoch (or kept from the previous edge's).
        let named = self.pps.and_then(|(t, s)| s.map(|s| (t, s)));
        let next = named
            .filter(|(t, _)| edge_us > *t && edge_us - t < PPS_VALID_US)
            .map(|(t, s)| s + ((edge_us - t) as i64 + 500_000) / 1_000_000 * 1_000_000);
        self.pps = Some((edge_us, next));
    }

    /// An epoch that arrived at `now_us`.
    pub fn take_epoch(&mut self, now_us: u64, p: &NavPvt) {
        let utc = (p.valid_date() && p.valid_time() && p.fully_resolved()).then(|| {
            unix_seconds(p.year, p.month, p.day, p.hour, p.min, p.sec) * 1_000_000
                + i64::from(p.nano_ns) / 1000
        });
        self.epoch = Some((now_us, utc));
        if let (Some(u), Some((t, _))) = (utc, self.pps) {
            if now_us >= t && now_us - t < PPS_VALID_US {
                // The edge's second: the epoch's UTC less the time since the edge, rounded.
                let s = u - (now_us - t) as i64;
                let named = (s + 500_000).div_euclid(1_000_000) * 1_000_000;
                self.pps = Some((t, Some(named)));
            }
        }
        self.fix = GnssFix {
            latitude: p.lat_e7,
            longitude: p.lon_e7,
            altitude: p.height_mm as f32 / 1000.0,
            altitude_msl: p.hmsl_mm as f32 / 1000.0,
            h_acc: p.h_acc_mm as f32 / 1000.0,
            v_acc: p.v_acc_mm as f32 / 1000.0,
            fix_type: if p.gnss_fix_ok() { p.fix_type } else { 0 },
            satellites: p.num_sv,
            ..self.fix
        };
    }

    /// What `imu/gnss` carries at `now_us`; `alive`: the receiver sends epochs.
    pub fn fix(&self, now_us: u64, alive: bool) -> GnssFix {
        let pps = self
            .pps
            .and_then(|(t, s)| Some((t, s?)))
            .filter(|(t, _)| now_us >= *t && now_us - t < PPS_VALID_US);
        let (utc, disciplined) = match (pps, self.epoch) {
            (Some((t, s)), _) => (s + (now_us - t) as i64, true),
            (None, Some((t, Some(u)))) => (u + (now_us - t) as i64, false),
            _ => (0, false),
        };
        GnssFix {
            utc_us: utc.max(0) as u64,
            pps: disciplined,
            status: if alive { crate::STATUS_OK } else { crate::STATUS_NO_DATA },
            ..self.fix
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unix_seconds_match_known_dates() {
        assert_eq!(unix_seconds(1970, 1, 1, 0, 0, 0), 0);
        assert_eq!(unix_seconds(2000, 3, 1, 0, 0, 0), 951_868_800);
        assert_eq!(unix_seconds(2024, 2, 29, 23, 59, 59), 1_709_251_199);
        assert_eq!(unix_seconds(2026, 11, 27, 12, 0, 0), 1_795_780_800);
        assert_eq!(unix_seconds(2100, 3, 1, 0, 0, 0), 4_107_542_400);
    }

    fn pvt(sec: u8, nano_ns: i32) -> NavPvt {
        NavPvt {
            year: 2026,
            month: 11,
            day: 27,
            hour: 12,
            min: 0,
            sec,
            nano_ns,
            valid: 0b111,
            fix_type: 3,
            flags: 1,
            num_sv: 11,
            lat_e7: 454_780_000,
            lon_e7: 92_270_000,
            height_mm: 169_500,
            hmsl_mm: 122_500,
            h_acc_mm: 1500,
            v_acc_mm: 2500,
            ..NavPvt::default()
        }
    }

    const NOON_US: i64 = 1_795_780_800_000_000;

    #[test]
    fn the_pulse_disciplines_utc_to_the_microsecond() {
        let mut g = Gnss::default();
        // The edge at 10.000 s on the module's clock marks 12:00:05; the 12:00:05.0 epoch
        // arrives 37 ms later, the 12:00:05.2 one at 10.241 s.
        g.take_pps(10_000_000);
        g.take_epoch(10_037_000, &pvt(5, 0));
        let f = g.fix(10_037_000, true);
        assert!(f.pps);
        assert_eq!(f.utc_us as i64, NOON_US + 5_000_000 + 37_000);
        g.take_epoch(10_241_000, &pvt(5, 200_000_000));
        assert_eq!(g.fix(10_500_000, true).utc_us as i64, NOON_US + 5_500_000);
        // The next edge is 12:00:06 without another epoch; half a second later UTC follows it.
        g.take_pps(11_000_013);
        assert_eq!(g.fix(11_500_013, true).utc_us as i64, NOON_US + 6_500_000);
        // The fix itself, in the message's units.
        let f = g.fix(11_500_013, true);
        assert_eq!(
            (f.latitude, f.longitude, f.fix_type, f.satellites),
            (454_780_000, 92_270_000, 3, 11)
        );
        assert_eq!((f.altitude, f.altitude_msl, f.h_acc, f.v_acc), (169.5, 122.5, 1.5, 2.5));
        // No edge for 1.5 s: UTC from the last epoch's arrival, not disciplined.
        let f = g.fix(12_600_000, true);
        assert!(!f.pps);
        assert_eq!(f.utc_us as i64, NOON_US + 5_200_000 + (12_600_000 - 10_241_000));
    }

    #[test]
    fn the_edge_is_named_by_the_epoch_after_it_and_only_a_recent_one() {
        // The first epoch after the edge is 12:00:05.4, arriving 430 ms after it: the edge is
        // 12:00:05 (5.4 − 0.43 = 4.97 rounds to 5), not 12:00:06.
        let mut g = Gnss::default();
        g.take_pps(10_000_000);
        g.take_epoch(10_430_000, &pvt(5, 400_000_000));
        assert_eq!(g.fix(10_500_000, true).utc_us as i64, NOON_US + 5_500_000);
        // An epoch 1.6 s after the last edge does not name it (the edge is no longer the top of
        // the second the epoch is in): UTC from the epoch, not disciplined.
        let mut g = Gnss::default();
        g.take_pps(10_000_000);
        g.take_epoch(11_600_000, &pvt(6, 600_000_000));
        let f = g.fix(11_700_000, true);
        assert_eq!((f.pps, f.utc_us as i64), (false, NOON_US + 6_700_000));
        // Edges missing for 2 s: the next one is not named from the old one; the next epoch
        // names it.
        let mut g = Gnss::default();
        g.take_pps(10_000_000);
        g.take_epoch(10_040_000, &pvt(5, 0));
        g.take_pps(13_000_000);
        assert!(!g.fix(13_100_000, true).pps);
        g.take_epoch(13_040_000, &pvt(8, 0));
        assert_eq!(g.fix(13_100_000, true).utc_us as i64, NOON_US + 8_100_000);
        // An edge a second on is named from the last: no epoch needed.
        g.take_pps(14_000_002);
        assert_eq!(g.fix(14_000_002, true).utc_us as i64, NOON_US + 9_000_000);
    }

    #[test]
    fn without_valid_time_or_a_fix_it_says_so() {
        let mut g = Gnss::default();
        assert_eq!(g.fix(0, false).status, crate::STATUS_NO_DATA);
        assert_eq!(g.fix(0, false).utc_us, 0);
        let mut p = pvt(5, 0);
        p.valid = 0b011; // not fully resolved
        p.flags = 0; // gnssFixOK clear: the fix type is not to be used
        g.take_pps(1_000_000);
        g.take_epoch(1_030_000, &p);
        let f = g.fix(1_100_000, true);
        assert_eq!((f.utc_us, f.pps, f.fix_type, f.status), (0, false, 0, crate::STATUS_OK));
    }

    #[test]
    fn the_link_configures_at_both_rates_then_listens_and_again_when_silent() {
        let mut l = Link::new(5);
        assert_eq!(l.poll(0), Some(Action::Send { baud: 38_400 }));
        assert_eq!(l.poll(1000), None, "86 bytes at 38 400 baud take 22 ms");
        assert_eq!(l.poll(27_000), None, "and 5 ms more");
        assert_eq!(l.poll(27_400), Some(Action::Send { baud: 9_600 }));
        assert_eq!(l.poll(100_000), None);
        assert_eq!(l.poll(122_000), Some(Action::Listen { baud: 38_400 }));
        assert_eq!(l.poll(2_000_000), None);
        // The configuration is NAV-PVT at 5 Hz: 200 ms in CFG-RATE.
        let mut want = [0; ubx::BOOT_CONFIG_LEN];
        ubx::boot_config(5, &mut want).unwrap();
        assert_eq!(l.config(), &want[..]);
        // An epoch keeps it listening; silence for 3 s starts over.
        let mut frame = [0u8; 100];
        let p = [0u8; ubx::NAV_PVT_LEN];
        let n = ubx::encode(ubx::CLASS_NAV, ubx::ID_NAV_PVT, &p, &mut frame).unwrap();
        assert!(l.receive(2_500_000, &frame[..n]).is_some());
        // A frame with a flipped bit is counted and dropped.
        frame[10] ^= 1;
        assert!(l.receive(2_600_000, &frame[..n]).is_none());
        assert_eq!((l.stats().frames, l.stats().checksum_errors), (1, 1));
        assert_eq!(l.poll(5_499_000), None);
        assert_eq!(l.poll(5_500_000), Some(Action::Send { baud: 38_400 }));
    }
}
