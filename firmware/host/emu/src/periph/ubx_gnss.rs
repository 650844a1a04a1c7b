//! Model of a u-blox GNSS receiver on a [`SimUart`] (issue 21): from power-up at its factory
//! settings (NMEA sentences at 1 Hz at its default baud rate) to UBX-NAV-PVT at 1–10 Hz once
//! the MCU has configured it, navigation solutions from the world's [`GnssReceiver`].
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
//! receiver's time pulse (PPS) marks the top of each UTC second ([`UbxGnssModel::pps_at`])
//! once the receiver has GNSS time, from its first fix: before it, no pulse. One pulse per
//! second is the default (NEO-M8 data sheet UBX-13003366 R07 §1.11); that it has length 0
//! until locked (CFG-TP-LEN_TP1 = 0, LEN_LOCK_TP1 = 100 ms) is NOT VERIFIED: the protocol
//! descriptions' default tables were not readable here — a firmware that counted free-running
//! edges as UTC seconds would be wrong, so the model gives none to count.
//!
//! **Power-up** ([`UbxGnssModel::powered_at`]): a receiver powered later than the world's
//! start (a board booted or a cable plugged then) starts cold: no backup supply on the
//! module's port, its time to first fix counts from its power-up, and its epochs follow on
//! the whole periods of UTC after it.
//!
//! **Factory settings** ([`UbxGnssModel::factory`]): UART1 at the generation's default rate
//! ([`Generation::default_baud`]: 9600 on M8, UBX-13003366 R07 Table 12 "Default messages";
//! 38400 on M10, NOT VERIFIED, see `r2p_drivers::ubx`), UBX and NMEA in, NMEA out, 1 Hz, no
//! UBX message enabled; the NMEA set each epoch is RMC, VTG, GGA, GSA, GSV, GLL (NMEA 4.10
//! fields, talker GN, GSV as GP), the receivers' default set (the M8's Table 12 lists GGA, GLL,
//! GSA, GSV, RMC, VTG and TXT; UBX-13003221 "NMEA protocol"; the TXT lines at start-up are not
//! modelled). Each sentence is `$…*hh\r\n` with the XOR checksum of the characters between
//! `$` and `*`, from the same solution as the NAV-PVT of that epoch (position in ddmm.mmmmm,
//! speed in knots and km/h, DOPs 1.20/0.94/0.75 with a fix). Satellites in GSV have made-up
//! PRNs, elevations, azimuths and C/N0: the world model gives their number only.
//!
//! **Configuration** arrives on the receiver's RX side ([`SimUart::device_receive`]), as
//! bytes at the receiver's baud (a frame sent at another rate arrives as other bytes and is
//! ignored, as a receiver ignores noise). Well-formed UBX-CFG frames are answered ACK-ACK or
//! ACK-NAK (class 0x05, UBX-18010854 §5.8) on the wire after the frame, when UBX output is on
//! (UBX-13003221: ACK "sent as soon as possible but at least within one second"):
//! - CFG-VALSET version 0 (M10; the M8 answers NAK, NOT VERIFIED): keys CFG-UART1-BAUDRATE,
//!   CFG-UART1OUTPROT-UBX/NMEA, CFG-MSGOUT-UBX_NAV_PVT_UART1, CFG-RATE-MEAS, CFG-RATE-NAV;
//!   any other key, no RAM layer, a measurement period under 25 ms: NAK, nothing applied
//!   (§5.9.27: "no configuration is applied" if a key is unknown or a value invalid);
//! - CFG-PRT (UART1, 20 bytes), CFG-MSG (3- and 8-byte forms; NAV-PVT and the NMEA standard
//!   messages F0 00–05), CFG-RATE (M8; the M10 has no legacy CFG messages: NAK). A new baud rate
//!   takes effect once the ACK is on the wire, so the host sees the ACK at the old rate.
//!
//! Other UBX classes are ignored (polls are not modelled), as are NMEA input and bad frames.
//!
//! Not modelled: polls (CFG-… with an empty or short payload are answered NAK here, a
//! receiver answers them with the configuration), saving to BBR/flash, CFG-VALSET
//! transactions (version 1), other UBX messages and NMEA sentences, TX buffer overflow when
//! the output exceeds the baud rate (bytes queue on the wire here).

use r2p_world::gnss::{FixType, GnssFix, GnssReceiver};

use super::uart::SimUart;

/// Class ACK / CFG and the ids the model answers.
const CLASS_ACK: u8 = 0x05;
const CLASS_CFG: u8 = 0x06;
const ID_CFG_PRT: u8 = 0x00;
const ID_CFG_MSG: u8 = 0x01;
const ID_CFG_RATE: u8 = 0x08;
const ID_CFG_VALSET: u8 = 0x8A;
/// Configuration keys (u-blox M10 interface description, configuration reference).
const KEY_UART1_BAUDRATE: u32 = 0x4052_0001;
const KEY_UART1OUTPROT_UBX: u32 = 0x1074_0001;
const KEY_UART1OUTPROT_NMEA: u32 = 0x1074_0002;
const KEY_MSGOUT_UBX_NAV_PVT_UART1: u32 = 0x2091_0007;
const KEY_RATE_MEAS: u32 = 0x3021_0001;
const KEY_RATE_NAV: u32 = 0x3021_0002;
/// The shortest measurement period, ms (UBX-18010854 §5.9.19: "should be greater than or
/// equal to 25 ms").
const MIN_MEAS_MS: u32 = 25;
/// The receiver's UART transmit buffer, bytes: a message that does not fit in what is still
/// waiting is dropped (NOT VERIFIED: u-blox gives no figure; CFG-PRT's TX-ready threshold
/// reaches 4088 bytes, UBX-18010854 §5.9.17.2).
pub const TX_BUFFER: u64 = 4096;
/// The largest UBX payload the model takes (CFG-VALSET's 64 key-value pairs of up to 8 bytes).
const MAX_RX_PAYLOAD: usize = 4 + 64 * 12;

const NS_PER_S: u64 = 1_000_000_000;
/// NAV-PVT's payload length.
pub const NAV_PVT_LEN: usize = 92;
/// A whole NAV-PVT frame: sync, class, id, length, payload, checksum.
pub const NAV_PVT_FRAME_LEN: usize = NAV_PVT_LEN + 8;
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

/// A UBX frame: sync, class, id, length, `payload`, checksum.
pub fn ubx_frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
    let mut f = vec![0xB5, 0x62, class, id];
    f.extend((payload.len() as u16).to_le_bytes());
    f.extend(payload);
    let ck = checksum(&f[2..]);
    f.extend(ck);
    f
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
    put(&mut p, 36, &mm(e.fix.position.height_m - e.fix.geoid_separation_m).to_le_bytes());
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

/// The receiver's generation: what it defaults to and which configuration messages it takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Generation {
    /// u-blox M8 (protocol 15–23): legacy CFG-PRT/MSG/RATE, no CFG-VALSET, 9600 baud.
    M8,
    /// u-blox M10 (protocol 34 and later): CFG-VALSET only, 38400 baud.
    M10,
}

impl Generation {
    /// UART1's factory baud rate.
    pub fn default_baud(self) -> u32 {
        match self {
            Generation::M8 => 9_600,
            Generation::M10 => 38_400,
        }
    }
}

/// The NMEA standard messages the model outputs, in the order a receiver sends them, with
/// their CFG-MSG ids (class 0xF0).
const NMEA_SET: [(u8, &str); 6] =
    [(0x04, "RMC"), (0x05, "VTG"), (0x00, "GGA"), (0x02, "GSA"), (0x03, "GSV"), (0x01, "GLL")];

/// The receiver's state on its UART.
#[derive(Clone, Debug)]
pub struct UbxGnssModel {
    receiver: GnssReceiver,
    generation: Generation,
    /// UART1's rate, or `None` to leave the line's device rate alone ([`UbxGnssModel::new`]).
    baud: Option<u32>,
    /// Navigation period, ms.
    period_ms: u32,
    /// Measurement period and solutions per navigation epoch (CFG-RATE / CFG-RATE-MEAS, -NAV).
    meas_ms: u32,
    nav_rate: u32,
    next_ns: u64,
    /// When it was powered up, ns of the world's time (its time to first fix counts from it).
    powered_ns: u64,
    /// UTC at power-up (t = 0), s since 1970, and the GPS time of week then, ms.
    start_unix_s: u64,
    start_tow_ms: u32,
    epochs: u64,
    nav_pvt_sent: u64,
    /// Output protocols on UART1.
    out_ubx: bool,
    out_nmea: bool,
    /// NAV-PVT every n-th epoch (0: off).
    nav_pvt_every: u8,
    /// NMEA standard messages, every n-th epoch, indexed as [`NMEA_SET`].
    nmea_every: [u8; 6],
    rx: Vec<u8>,
    acks: u64,
    naks: u64,
    tx_dropped: u64,
}

impl UbxGnssModel {
    /// A receiver powered up at t = 0, when UTC was `start_unix_s` (a whole second) and the GPS
    /// time of week `start_tow_ms`, already configured (stored in its flash) to send NAV-PVT
    /// alone at `rate_hz` (1–10 Hz) on the top of its seconds' fractions, at the line's baud
    /// rate. An M8; it answers configuration as [`UbxGnssModel::factory`]'s does.
    pub fn new(receiver: GnssReceiver, rate_hz: u32, start_unix_s: u64, start_tow_ms: u32) -> Self {
        let rate_hz = rate_hz.clamp(1, 10);
        let mut m = Self::factory(receiver, Generation::M8, start_unix_s, start_tow_ms);
        m.baud = None;
        m.meas_ms = 1000 / rate_hz;
        m.period_ms = m.meas_ms;
        m.next_ns = u64::from(m.period_ms) * 1_000_000;
        m.out_nmea = false;
        m.nav_pvt_every = 1;
        m
    }

    /// A receiver of `generation` powered up at t = 0 with its factory settings: NMEA at 1 Hz
    /// at [`Generation::default_baud`], no UBX output until configured (see the module
    /// documentation). It sets the line's device baud rate itself.
    pub fn factory(
        receiver: GnssReceiver,
        generation: Generation,
        start_unix_s: u64,
        start_tow_ms: u32,
    ) -> Self {
        Self {
            receiver,
            generation,
            baud: Some(generation.default_baud()),
            period_ms: 1000,
            meas_ms: 1000,
            nav_rate: 1,
            next_ns: NS_PER_S,
            powered_ns: 0,
            start_unix_s,
            start_tow_ms,
            epochs: 0,
            nav_pvt_sent: 0,
            out_ubx: true,
            out_nmea: true,
            nav_pvt_every: 0,
            nmea_every: [1; 6],
            rx: Vec::new(),
            acks: 0,
            naks: 0,
            tx_dropped: 0,
        }
    }

    /// Epochs solved so far (whatever was sent for them).
    pub fn epochs(&self) -> u64 {
        self.epochs
    }

    /// NAV-PVT frames sent so far (not those dropped for a full transmit buffer).
    pub fn nav_pvt_sent(&self) -> u64 {
        self.nav_pvt_sent
    }

    /// Messages dropped because the transmit buffer was full ([`TX_BUFFER`]).
    pub fn tx_dropped(&self) -> u64 {
        self.tx_dropped
    }

    /// Queues `msg` at `at_ns` unless the bytes still waiting and it exceed [`TX_BUFFER`].
    fn send(&mut self, uart: &mut SimUart, at_ns: u64, msg: &[u8]) -> bool {
        let byte_ns = 10 * NS_PER_S / u64::from(uart.device_baud());
        let waiting = uart.device_free_at().saturating_sub(at_ns) / byte_ns;
        if waiting + msg.len() as u64 > TX_BUFFER {
            self.tx_dropped += 1;
            return false;
        }
        uart.device_send_at(at_ns, msg);
        true
    }

    /// ACK-ACK and ACK-NAK sent so far.
    pub fn acks_naks(&self) -> (u64, u64) {
        (self.acks, self.naks)
    }

    /// UART1's baud rate (`None`: the line's, for a receiver made by [`UbxGnssModel::new`] and
    /// not told another).
    pub fn baud(&self) -> Option<u32> {
        self.baud
    }

    /// The navigation rate, Hz.
    pub fn rate_hz(&self) -> f64 {
        1000.0 / f64::from(self.period_ms)
    }

    /// Whether UART1 outputs NMEA, and NAV-PVT.
    pub fn output(&self) -> (bool, bool) {
        (
            self.out_nmea && self.nmea_every.iter().any(|&n| n > 0),
            self.out_ubx && self.nav_pvt_every > 0,
        )
    }

    /// This receiver powered up at `now_ns` instead of the world's time 0 (UTC still counted
    /// from the world's start): cold, its first epoch on the next whole period, its first fix
    /// its time to first fix later.
    pub fn powered_at(mut self, now_ns: u64) -> Self {
        let period = u64::from(self.period_ms) * 1_000_000;
        self.powered_ns = now_ns;
        self.next_ns = (now_ns / period + 1) * period;
        self
    }

    /// The time pulse's rising edge at or after `t_ns`, ns: the top of each UTC second from
    /// the first the receiver has its time (its first fix, `GnssParams::ttff_s` after its
    /// power-up).
    pub fn pps_at(&self, t_ns: u64) -> u64 {
        let locked = self.powered_ns + (self.receiver.params.ttff_s * NS_PER_S as f64) as u64;
        t_ns.max(locked).div_ceil(NS_PER_S) * NS_PER_S
    }

    /// Takes the configuration the MCU sent, then sends the epochs due by `now_ns`, the antenna
    /// at `antenna_enu` metres from the world's origin moving at `velocity_enu` m/s.
    pub fn update(
        &mut self,
        now_ns: u64,
        uart: &mut SimUart,
        antenna_enu: [f64; 3],
        velocity_enu: [f64; 3],
    ) {
        if let Some(baud) = self.baud {
            uart.set_device_baud(baud);
        }
        let received = uart.device_receive();
        self.receive(now_ns, uart, &received);
        while self.next_ns <= now_ns {
            let t_ms = self.next_ns / 1_000_000;
            let since_power_up = (self.next_ns - self.powered_ns) as f64 / NS_PER_S as f64;
            let fix = self.receiver.solve(since_power_up, antenna_enu);
            let epoch = PvtEpoch {
                itow_ms: ((u64::from(self.start_tow_ms) + t_ms) % 604_800_000) as u32,
                utc: Utc::from_unix(self.start_unix_s + t_ms / 1000),
                fix,
                velocity_enu,
            };
            let at = self.next_ns;
            if self.out_nmea {
                for (i, &(_, kind)) in NMEA_SET.iter().enumerate() {
                    let every = u64::from(self.nmea_every[i]);
                    if every > 0 && self.epochs.is_multiple_of(every) {
                        let lines = nmea(kind, &epoch, (t_ms % 1000) as u32).concat();
                        self.send(uart, at, lines.as_bytes());
                    }
                }
            }
            let every = u64::from(self.nav_pvt_every);
            if self.out_ubx && every > 0 && self.epochs.is_multiple_of(every) {
                self.nav_pvt_sent += u64::from(self.send(uart, at, &nav_pvt(&epoch)));
            }
            self.epochs += 1;
            self.next_ns += u64::from(self.period_ms) * 1_000_000;
        }
    }

    /// Bytes at the receiver's RX: complete UBX frames are taken, anything else is dropped.
    fn receive(&mut self, now_ns: u64, uart: &mut SimUart, bytes: &[u8]) {
        self.rx.extend_from_slice(bytes);
        loop {
            // Hunt for the sync pair.
            match self.rx.windows(2).position(|w| w == [0xB5, 0x62]) {
                Some(i) => drop(self.rx.drain(..i)),
                None => {
                    let keep = usize::from(self.rx.last() == Some(&0xB5));
                    let n = self.rx.len() - keep;
                    self.rx.drain(..n);
                    return;
                }
            }
            let Some(&[l0, l1]) = self.rx.get(4..6) else { return };
            let len = usize::from(u16::from_le_bytes([l0, l1]));
            if len > MAX_RX_PAYLOAD {
                self.rx.drain(..2);
                continue;
            }
            if self.rx.len() < len + 8 {
                return;
            }
            let frame: Vec<u8> = self.rx[..len + 8].to_vec();
            if checksum(&frame[2..6 + len]) != frame[6 + len..] {
                self.rx.drain(..2); // noise that looked like a frame: hunt on inside it
                continue;
            }
            self.rx.drain(..len + 8);
            self.configure(now_ns, uart, frame[2], frame[3], &frame[6..6 + len]);
        }
    }

    /// One well-formed frame from the MCU.
    fn configure(&mut self, now_ns: u64, uart: &mut SimUart, class: u8, id: u8, p: &[u8]) {
        if class != CLASS_CFG {
            return;
        }
        let mut new_baud = None;
        let ok = match (self.generation, id) {
            (Generation::M10, ID_CFG_VALSET) => self.valset(now_ns, p, &mut new_baud),
            (Generation::M8, ID_CFG_PRT) if p.len() == 20 && p[0] == 1 => {
                let baud = u32::from_le_bytes([p[8], p[9], p[10], p[11]]);
                let (in_mask, out_mask) = (p[12], p[14]);
                if baud == 0 || in_mask & 3 == 0 {
                    false
                } else {
                    self.out_ubx = out_mask & 1 != 0;
                    self.out_nmea = out_mask & 2 != 0;
                    new_baud = Some(baud);
                    true
                }
            }
            (Generation::M8, ID_CFG_MSG) if p.len() == 3 || p.len() == 8 => {
                // The 8-byte form gives six ports' rates: UART1 is port 1.
                let rate = if p.len() == 3 { p[2] } else { p[3] };
                self.set_msg_rate(p[0], p[1], rate);
                true
            }
            (Generation::M8, ID_CFG_RATE) if p.len() == 6 => {
                let meas = u32::from(u16::from_le_bytes([p[0], p[1]]));
                let nav = u32::from(u16::from_le_bytes([p[2], p[3]]));
                let time_ref = u16::from_le_bytes([p[4], p[5]]);
                if meas < MIN_MEAS_MS || !(1..=127).contains(&nav) || time_ref > 4 {
                    false
                } else {
                    self.set_rate_at_next(now_ns, meas, nav);
                    true
                }
            }
            _ => false,
        };
        let at = now_ns.max(uart.device_free_at());
        let ack = ubx_frame(CLASS_ACK, u8::from(ok), &[CLASS_CFG, id]);
        if !self.send(uart, at, &ack) {
        } else if ok {
            self.acks += 1;
        } else {
            self.naks += 1;
        }
        if let Some(baud) = new_baud {
            self.baud = Some(baud);
            uart.set_device_baud(baud);
        }
    }

    /// CFG-VALSET version 0: every key known and every value valid, or nothing applied.
    fn valset(&mut self, now_ns: u64, p: &[u8], new_baud: &mut Option<u32>) -> bool {
        if p.len() < 4 || p[0] != 0 || p[1] & 1 == 0 {
            return false;
        }
        let mut items = Vec::new();
        let mut i = 4;
        while i < p.len() {
            let Some(k) = p.get(i..i + 4) else { return false };
            let key = u32::from_le_bytes([k[0], k[1], k[2], k[3]]);
            let size = match (key >> 28) & 7 {
                1 | 2 => 1,
                3 => 2,
                4 => 4,
                5 => 8,
                _ => return false,
            };
            let Some(v) = p.get(i + 4..i + 4 + size) else { return false };
            let mut b = [0u8; 8];
            b[..size].copy_from_slice(v);
            items.push((key, u64::from_le_bytes(b)));
            i += 4 + size;
        }
        let (mut meas, mut nav) = (self.meas_ms, self.nav_rate);
        for &(key, v) in &items {
            match key {
                KEY_RATE_MEAS => meas = v as u32,
                KEY_RATE_NAV => nav = v as u32,
                KEY_UART1_BAUDRATE if v > 0 => {}
                KEY_UART1OUTPROT_UBX | KEY_UART1OUTPROT_NMEA if v <= 1 => {}
                KEY_MSGOUT_UBX_NAV_PVT_UART1 => {}
                _ => return false,
            }
        }
        if meas < MIN_MEAS_MS || !(1..=127).contains(&nav) {
            return false;
        }
        for &(key, v) in &items {
            match key {
                KEY_UART1_BAUDRATE => *new_baud = Some(v as u32),
                KEY_UART1OUTPROT_UBX => self.out_ubx = v == 1,
                KEY_UART1OUTPROT_NMEA => self.out_nmea = v == 1,
                KEY_MSGOUT_UBX_NAV_PVT_UART1 => self.nav_pvt_every = v as u8,
                _ => {}
            }
        }
        self.set_rate_at_next(now_ns, meas, nav);
        true
    }

    fn set_msg_rate(&mut self, class: u8, id: u8, rate: u8) {
        match (class, id) {
            (0x01, 0x07) => self.nav_pvt_every = rate,
            (0xF0, _) => {
                if let Some(i) = NMEA_SET.iter().position(|&(nid, _)| nid == id) {
                    self.nmea_every[i] = rate;
                }
            }
            _ => {} // accepted, not modelled
        }
    }

    /// A new navigation period: the next epoch on the new grid (epochs are aligned to the top
    /// of the second, UBX-18010854 §5.9.19) after `now_ns`.
    fn set_rate_at_next(&mut self, now_ns: u64, meas_ms: u32, nav: u32) {
        if (meas_ms, nav) == (self.meas_ms, self.nav_rate) {
            return;
        }
        self.meas_ms = meas_ms;
        self.nav_rate = nav;
        self.period_ms = meas_ms * nav;
        let period = u64::from(self.period_ms) * 1_000_000;
        self.next_ns = (now_ns / period + 1) * period;
    }
}

/// The NMEA checksum: XOR of the characters between `$` and `*`.
pub fn nmea_checksum(body: &str) -> u8 {
    body.bytes().fold(0, |c, b| c ^ b)
}

/// `$body*hh\r\n`.
fn sentence(body: String) -> String {
    format!("${body}*{:02X}\r\n", nmea_checksum(&body))
}

/// Latitude or longitude as NMEA's d…dmm.mmmmm and hemisphere.
fn nmea_angle(deg: f64, width: usize, pos: char, neg: char) -> String {
    let a = deg.abs();
    let mut d = a.trunc();
    let mut m = ((a - d) * 60.0 * 1e5).round() / 1e5;
    if m >= 60.0 {
        d += 1.0;
        m -= 60.0;
    }
    format!("{:0width$}{:08.5},{}", d as u32, m, if deg < 0.0 { neg } else { pos })
}

/// The sentences of one NMEA standard message `kind` for epoch `e`, `ms` the epoch's
/// milliseconds within its second.
pub fn nmea(kind: &str, e: &PvtEpoch, ms: u32) -> Vec<String> {
    let fixed = e.fix.fix == FixType::Fix3d;
    let u = e.utc;
    let time = if fixed {
        format!("{:02}{:02}{:02}.{:02}", u.hour, u.min, u.sec, ms / 10)
    } else {
        String::new()
    };
    let date = if fixed {
        format!("{:02}{:02}{:02}", u.day, u.month, u.year % 100)
    } else {
        String::new()
    };
    let (lat, lon) = if fixed {
        (
            nmea_angle(e.fix.position.lat_deg, 2, 'N', 'S'),
            nmea_angle(e.fix.position.lon_deg, 3, 'E', 'W'),
        )
    } else {
        (",".to_string(), ",".to_string())
    };
    let [ve, vn, _] = e.velocity_enu;
    let speed = ve.hypot(vn);
    let cog = ve.atan2(vn).to_degrees().rem_euclid(360.0);
    let (status, mode) = if fixed { ("A", "A") } else { ("V", "N") };
    let (geoid, msl) =
        (e.fix.geoid_separation_m, e.fix.position.height_m - e.fix.geoid_separation_m);
    match kind {
        "RMC" => vec![sentence(format!(
            "GNRMC,{time},{status},{lat},{lon},{},{},{date},,,{mode},V",
            if fixed { format!("{:.3}", speed / 0.514_444) } else { String::new() },
            if fixed { format!("{cog:.2}") } else { String::new() },
        ))],
        "VTG" => vec![sentence(if fixed {
            format!("GNVTG,{cog:.2},T,,M,{:.3},N,{:.3},K,A", speed / 0.514_444, speed * 3.6)
        } else {
            "GNVTG,,,,,,,,,N".to_string()
        })],
        "GGA" => vec![sentence(if fixed {
            format!(
                "GNGGA,{time},{lat},{lon},1,{:02},0.94,{msl:.1},M,{geoid:.1},M,,",
                e.fix.satellites
            )
        } else {
            "GNGGA,,,,,,0,00,99.99,,,,,,".to_string()
        })],
        "GSA" => {
            let mut svs: Vec<String> = satellites(e.fix.satellites)
                .iter()
                .take(12)
                .map(|s| format!("{:02}", s.0))
                .collect();
            svs.resize(12, String::new());
            let (f, dops) =
                if fixed { ("3", "1.20,0.94,0.75") } else { ("1", "99.99,99.99,99.99") };
            vec![sentence(format!("GNGSA,A,{f},{},{dops},1", svs.join(",")))]
        }
        "GSV" => {
            let sats = satellites(e.fix.satellites);
            let n = sats.len().div_ceil(4).max(1);
            (0..n)
                .map(|i| {
                    let mut body = format!("GPGSV,{n},{},{:02}", i + 1, sats.len());
                    for s in sats.iter().skip(4 * i).take(4) {
                        body += &format!(",{:02},{:02},{:03},{:02}", s.0, s.1, s.2, s.3);
                    }
                    sentence(body + ",1")
                })
                .collect()
        }
        "GLL" => vec![sentence(format!("GNGLL,{lat},{lon},{time},{status},{mode}"))],
        _ => Vec::new(),
    }
}

/// `n` satellites as (PRN, elevation °, azimuth °, C/N0 dB-Hz): made up, deterministic.
fn satellites(n: u8) -> Vec<(u8, u8, u16, u8)> {
    (0..n)
        .map(|i| {
            let i16 = u16::from(i);
            (1 + (i * 7) % 32, 15 + (i * 23) % 70, (i16 * 137) % 360, 30 + (i * 5) % 16)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_io::{Read, Write};
    use r2p_world::gnss::{Geodetic, GnssParams};
    use ublox::proto23::{PacketRef, Proto23};
    use ublox::{GnssFixType, Parser, UbxPacket};

    const ORIGIN: Geodetic = Geodetic { lat_deg: 45.478, lon_deg: 9.227, height_m: 170.0 };
    /// The geoid's separation at the origin: not Milan's 47 m, so that a constant shows.
    const GEOID_M: f64 = 48.3;
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

    /// Runs `gnss` every 10 ms over `ms` with the antenna still at `enu` moving at `velocity`, on
    /// a 115 200 baud line, and maps each NAV-PVT the `ublox` crate decodes off it.
    fn nav_pvts<T>(
        gnss: &mut UbxGnssModel,
        ms: core::ops::Range<u64>,
        enu: [f64; 3],
        velocity: [f64; 3],
        take: impl Fn(&ublox::packets::nav_pvt::proto23::NavPvtRef<'_>) -> T,
    ) -> Vec<T> {
        let mut uart = SimUart::new(115_200, 4096);
        let mut parser = Parser::<_, Proto23>::new(Vec::new());
        let mut seen = Vec::new();
        for ms in ms.step_by(10) {
            let t = ms * 1_000_000;
            gnss.update(t, &mut uart, enu, velocity);
            uart.advance_to(t);
            let mut buf = [0u8; 256];
            let n = uart.read(&mut buf).unwrap_or(0);
            let mut it = parser.consume_ubx(&buf[..n]);
            while let Some(p) = it.next() {
                if let Ok(UbxPacket::Proto23(PacketRef::NavPvt(pvt))) = p {
                    seen.push(take(&pvt));
                }
            }
        }
        seen
    }

    #[test]
    fn the_ublox_crate_decodes_our_nav_pvt_over_the_uart() {
        let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 5, 0);
        let mut gnss = UbxGnssModel::new(rx, 5, NOON, 475_218_000);
        let seen = nav_pvts(&mut gnss, 0..30_000, [12.0, -3.0, 0.5], [0.3, 0.4, 0.0], |pvt| {
            (
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
            )
        });
        // 5 Hz for 30 s, the last epoch's bytes still on the wire.
        assert!((148..=150).contains(&seen.len()), "{} epochs", seen.len());
        let early = seen[0];
        assert_eq!((early.0, early.1, early.2), (475_218_200, GnssFixType::NoFix, 0));
        let last = *seen.last().unwrap();
        assert_eq!((last.1, last.2), (GnssFixType::Fix3D, 12));
        let back = ORIGIN.enu_to(&Geodetic { lat_deg: last.3, lon_deg: last.4, height_m: last.5 });
        let tol = 5.0 * GnssParams::UBLOX_M8.sigma_h_m; // 5 σ of the receiver's error
        assert!((back[0] - 12.0).abs() < tol && (back[1] + 3.0).abs() < tol, "{back:?}");
        assert!((last.6 - 0.5).abs() < 1e-3 && (last.7 - 36.8699).abs() < 1e-3, "{last:?}");
        assert_eq!(last.8, 29, "UTC second of the epoch at 29.8 s");
        // Accuracy: unknown (u32::MAX mm) before the fix, the receiver's σ after it.
        assert_eq!((early.9, early.10), (f64::from(u32::MAX) / 1e3, f64::from(u32::MAX) / 1e3));
        let p = GnssParams::UBLOX_M8;
        assert_eq!((last.9, last.10), (p.sigma_h_m, p.sigma_v_m));
        // One epoch each 0.2 s up to 29.8 s: 149 sent (the parser saw them all but any still
        // on the wire).
        assert_eq!(gnss.epochs(), 149);
    }

    #[test]
    fn a_corrupted_frame_fails_its_checksum_in_the_ublox_parser() {
        let e = PvtEpoch {
            itow_ms: 1,
            utc: Utc::from_unix(NOON),
            fix: GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 1, 0)
                .solve(0.0, [0.0; 3]),
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

    /// Sentences in `bytes`: each `$…*hh\r\n` with a good checksum, returned without them.
    fn sentences(bytes: &[u8]) -> Vec<String> {
        let text = std::str::from_utf8(bytes).expect("NMEA is ASCII");
        assert!(text.ends_with("\r\n"));
        text.split_terminator("\r\n")
            .map(|line| {
                let (body, ck) = line.strip_prefix('$').unwrap().split_once('*').unwrap();
                assert_eq!(u8::from_str_radix(ck, 16).unwrap(), nmea_checksum(body), "{line}");
                body.to_string()
            })
            .collect()
    }

    #[test]
    fn nmea_checksums_of_u_bloxs_examples() {
        // GGA and RMC examples of the u-blox 8 / M8 description (UBX-13003221, NMEA protocol).
        let gga = "GPGGA,092725.00,4717.11399,N,00833.91590,E,1,08,1.01,499.6,M,48.0,M,,";
        assert_eq!(nmea_checksum(gga), 0x5B);
        let rmc = "GPRMC,083559.00,A,4717.11437,N,00833.91522,E,0.004,77.52,091202,,,A";
        assert_eq!(nmea_checksum(rmc), 0x57);
        assert_eq!(nmea_angle(47.285_239_5, 2, 'N', 'S'), "4717.11437,N");
        assert_eq!(nmea_angle(-8.565_253_7, 3, 'E', 'W'), "00833.91522,W");
        // Minutes that round up to 60 carry into the degrees.
        assert_eq!(nmea_angle(9.999_999_99, 3, 'E', 'W'), "01000.00000,E");
    }

    #[test]
    fn factory_m8_sends_nmea_at_9600_from_the_same_fix_and_no_ubx() {
        let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 7, 0);
        let mut gnss = UbxGnssModel::factory(rx, Generation::M8, NOON, 475_218_000);
        let mut uart = SimUart::new(9_600, 1 << 16);
        let mut bytes = Vec::new();
        for ms in 1..=40_000u64 {
            gnss.update(ms * 1_000_000, &mut uart, [12.0, -3.0, 0.5], [0.3, 0.4, 0.0]);
            uart.advance_to(ms * 1_000_000);
            let mut b = [0u8; 256];
            let n = uart.read(&mut b).unwrap_or(0);
            bytes.extend(&b[..n]);
        }
        assert_eq!(uart.device_baud(), 9_600);
        assert!(!bytes.contains(&0xB5), "no UBX before it is configured");
        assert_eq!((gnss.epochs(), gnss.nav_pvt_sent(), gnss.tx_dropped()), (40, 0, 0));
        let lines = sentences(&bytes);
        let kinds: Vec<&str> = lines.iter().map(|l| &l[..5]).collect();
        // Per epoch RMC, VTG, GGA, GSA, GSV (1 sentence without satellites, 3 with 12), GLL.
        assert_eq!(kinds[..6], ["GNRMC", "GNVTG", "GNGGA", "GNGSA", "GPGSV", "GNGLL"]);
        assert_eq!(lines[0], "GNRMC,,V,,,,,,,,,,N,V"); // 13 fields, NMEA 4.10
        assert_eq!(lines[2], "GNGGA,,,,,,0,00,99.99,,,,,,");
        let last: Vec<&String> = lines.iter().rev().take(8).collect();
        let [gll, gsv3, _, gsv1, gsa, gga, vtg, rmc] = last[..] else { panic!() };
        // The epoch at 39 s (40 s's is on the wire): 12:00:39 UTC, 3-D fix, 12 satellites.
        assert!(rmc.starts_with("GNRMC,120039.00,A,45"), "{rmc}");
        assert!(rmc.ends_with(",0.972,36.87,271126,,,A,V"), "{rmc}"); // 0.5 m/s in knots
        assert_eq!(vtg, "GNVTG,36.87,T,,M,0.972,N,1.800,K,A");
        assert!(gga.starts_with("GNGGA,120039.00,45") && gga.contains(",1,12,0.94,"), "{gga}");
        assert!(gga.ends_with(",M,48.3,M,,"), "{gga}");
        assert!(gsa.starts_with("GNGSA,A,3,01,08,15,") && gsa.ends_with(",1.20,0.94,0.75,1"));
        assert!(gsv1.starts_with("GPGSV,3,1,12,01,15,000,30,"), "{gsv1}");
        assert!(gsv3.starts_with("GPGSV,3,3,12,") && gsv3.ends_with(",1"), "{gsv3}");
        assert!(gll.ends_with(",120039.00,A,A"), "{gll}");
        // GGA's position is NAV-PVT's: latitude and longitude to 1e-5 minute, height above MSL.
        let f: Vec<&str> = gga.split(',').collect();
        let lat = f[2][..2].parse::<f64>().unwrap() + f[2][2..].parse::<f64>().unwrap() / 60.0;
        let lon = f[4][..3].parse::<f64>().unwrap() + f[4][3..].parse::<f64>().unwrap() / 60.0;
        let back = ORIGIN.enu_to(&Geodetic { lat_deg: lat, lon_deg: lon, height_m: 170.0 });
        let tol = 5.0 * GnssParams::UBLOX_M8.sigma_h_m; // 5 σ of the receiver's error
        assert!((back[0] - 12.0).abs() < tol && (back[1] + 3.0).abs() < tol, "{back:?}");
        let msl: f64 = f[9].parse().unwrap();
        assert!((msl - (170.5 - 48.3)).abs() < 10.0, "{msl}");
    }

    /// Sends `frame` to a receiver, returns what it answered.
    fn answer(
        gnss: &mut UbxGnssModel,
        uart: &mut SimUart,
        t_ms: &mut u64,
        frame: &[u8],
    ) -> Vec<u8> {
        uart.write_all(frame).unwrap();
        let mut out = Vec::new();
        for _ in 0..200 {
            *t_ms += 1;
            gnss.update(*t_ms * 1_000_000, uart, [0.0; 3], [0.0; 3]);
            uart.advance_to(*t_ms * 1_000_000);
            let mut b = [0u8; 1024];
            let n = uart.read(&mut b).unwrap_or(0);
            out.extend(&b[..n]);
        }
        out
    }

    fn contains(hay: &[u8], needle: &[u8]) -> bool {
        hay.windows(needle.len()).any(|w| w == needle)
    }

    #[test]
    fn configuration_is_acked_applied_or_nakked() {
        let ack = |id| ubx_frame(CLASS_ACK, 1, &[CLASS_CFG, id]);
        let nak = |id| ubx_frame(CLASS_ACK, 0, &[CLASS_CFG, id]);
        let rx = || GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 1, 0);
        let mut t = 0;
        // M8: CFG-RATE 250 ms × 2, CFG-MSG NAV-PVT (8-byte form: UART1 is the second rate),
        // CFG-MSG NMEA off; CFG-RATE under 25 ms, navRate 0 or timeRef 5 refused; VALSET too.
        let mut m8 = UbxGnssModel::factory(rx(), Generation::M8, NOON, 0);
        let mut uart = SimUart::new(9_600, 4096);
        let a = answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, 8, &[250, 0, 2, 0, 1, 0]));
        assert!(contains(&a, &ack(8)));
        assert_eq!(m8.rate_hz(), 2.0);
        for bad in [[24, 0, 1, 0, 1, 0], [100, 0, 0, 0, 1, 0], [100, 0, 1, 0, 5, 0]] {
            let a = answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, 8, &bad));
            assert!(contains(&a, &nak(8)), "{bad:?}");
        }
        assert_eq!(m8.rate_hz(), 2.0);
        let a = answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, 1, &[1, 7, 0, 2, 0, 0, 0, 0]));
        assert!(contains(&a, &ack(1)));
        assert_eq!(m8.output(), (true, true));
        let a = answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, 0x8A, &[0, 1, 0, 0]));
        assert!(contains(&a, &nak(0x8A)));
        // NAV-PVT every 2nd epoch at 2 Hz: 10 in 10 s.
        let sent = m8.nav_pvt_sent();
        for _ in 0..50 {
            answer(&mut m8, &mut uart, &mut t, &[]);
        }
        assert_eq!(m8.nav_pvt_sent() - sent, 10);
        // The NMEA messages can be turned off one by one.
        for id in 0..6 {
            let a = answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, 1, &[0xF0, id, 0]));
            assert!(contains(&a, &ack(1)));
        }
        assert_eq!(m8.output(), (false, true));
        // CFG-PRT of another port, and a poll (empty payload): NAK; nothing changes.
        let mut prt2 = [0u8; 20];
        prt2[0] = 2;
        prt2[8..12].copy_from_slice(&115_200u32.to_le_bytes());
        prt2[12] = 1;
        assert!(contains(&answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, 0, &prt2)), &nak(0)));
        assert!(contains(&answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, 0, &[])), &nak(0)));
        assert_eq!(m8.baud(), Some(9_600));
        // Other classes and broken frames are ignored: no answer.
        let mut broken = ubx_frame(6, 8, &[100, 0, 1, 0, 1, 0]);
        broken[7] ^= 1;
        let before = m8.acks_naks();
        answer(&mut m8, &mut uart, &mut t, &broken);
        answer(&mut m8, &mut uart, &mut t, &ubx_frame(1, 7, &[]));
        assert_eq!(m8.acks_naks(), before);
        assert_eq!(before, (8, 6));

        // M10: VALSET applies all or nothing; legacy CFG refused.
        let mut m10 = UbxGnssModel::factory(rx(), Generation::M10, NOON, 0);
        let mut uart = SimUart::new(38_400, 4096);
        let valset = |items: &[(u32, &[u8])]| {
            let mut p = vec![0u8, 1, 0, 0];
            for (k, v) in items {
                p.extend(k.to_le_bytes());
                p.extend(*v);
            }
            ubx_frame(6, 0x8A, &p)
        };
        let a = answer(&mut m10, &mut uart, &mut t, &ubx_frame(6, 8, &[100, 0, 1, 0, 1, 0]));
        assert!(contains(&a, &nak(8)));
        let good = valset(&[(KEY_RATE_MEAS, &[50, 0]), (KEY_RATE_NAV, &[2, 0])]);
        assert!(contains(&answer(&mut m10, &mut uart, &mut t, &good), &ack(0x8A)));
        assert_eq!(m10.rate_hz(), 10.0);
        let unknown = valset(&[(KEY_UART1OUTPROT_NMEA, &[0]), (0x5099_0001, &[0; 8])]);
        assert!(contains(&answer(&mut m10, &mut uart, &mut t, &unknown), &nak(0x8A)));
        let cut = &valset(&[(KEY_RATE_MEAS, &[50, 0])]);
        let mut short = cut[6..cut.len() - 3].to_vec(); // the value's second byte missing
        short.truncate(short.len());
        let short = ubx_frame(6, 0x8A, &short);
        assert!(contains(&answer(&mut m10, &mut uart, &mut t, &short), &nak(0x8A)));
        let bad_size = valset(&[(0x0099_0001, &[0])]);
        assert!(contains(&answer(&mut m10, &mut uart, &mut t, &bad_size), &nak(0x8A)));
        let bad_bool = valset(&[(KEY_UART1OUTPROT_UBX, &[2])]);
        assert!(contains(&answer(&mut m10, &mut uart, &mut t, &bad_bool), &nak(0x8A)));
        assert_eq!(m10.output(), (true, false));
        // A new baud rate: the ACK at the old one, then the switch.
        let baud = valset(&[(KEY_UART1_BAUDRATE, &115_200u32.to_le_bytes())]);
        let a = answer(&mut m10, &mut uart, &mut t, &baud);
        assert!(contains(&a, &ack(0x8A)));
        assert_eq!((m10.baud(), uart.device_baud()), (Some(115_200), 115_200));
    }

    #[test]
    fn the_receive_side_skips_oversize_lengths_and_takes_the_longest_valset() {
        let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 1, 0);
        let mut m10 = UbxGnssModel::factory(rx, Generation::M10, NOON, 0);
        let mut uart = SimUart::new(38_400, 1 << 16);
        let mut t = 0;
        let nak = ubx_frame(CLASS_ACK, 0, &[CLASS_CFG, ID_CFG_VALSET]);
        // A header whose length is over the largest payload, then a frame: the header is
        // dropped and the frame answered.
        let mut s = vec![0x00, 0xB5, 0x62, 0x06, 0x8A, 0xFF, 0xFF];
        s.extend(ubx_frame(6, 0x8A, &[0, 1, 0, 0, 0x01, 0x00, 0x21, 0x30, 100, 0]));
        let a = answer(&mut m10, &mut uart, &mut t, &s);
        assert!(contains(&a, &ubx_frame(CLASS_ACK, 1, &[CLASS_CFG, ID_CFG_VALSET])));
        // The longest CFG-VALSET: 64 eight-byte values, a 772-byte payload (unknown keys: NAK).
        let mut p = vec![0u8, 1, 0, 0];
        for _ in 0..64 {
            p.extend(0x5099_0001u32.to_le_bytes());
            p.extend([0u8; 8]);
        }
        assert_eq!(p.len(), MAX_RX_PAYLOAD);
        // 780 bytes take 203 ms at 38400 baud: two rounds of answer().
        let mut a = answer(&mut m10, &mut uart, &mut t, &ubx_frame(6, 0x8A, &p));
        a.extend(answer(&mut m10, &mut uart, &mut t, &[]));
        assert!(contains(&a, &nak));
    }

    #[test]
    fn m8_refuses_polls_and_ports_it_cannot_set() {
        let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 1, 0);
        let mut m8 = UbxGnssModel::factory(rx, Generation::M8, NOON, 0);
        let mut uart = SimUart::new(9_600, 1 << 16);
        let mut t = 0;
        let nak = |id| ubx_frame(CLASS_ACK, 0, &[CLASS_CFG, id]);
        // Polls (CFG-MSG with class and id only, CFG-RATE empty) are not modelled: NAK.
        let a = answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, ID_CFG_MSG, &[1, 7]));
        assert!(contains(&a, &nak(ID_CFG_MSG)));
        let a = answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, ID_CFG_RATE, &[]));
        assert!(contains(&a, &nak(ID_CFG_RATE)));
        // CFG-PRT for UART1 with baud 0, or with no input protocol (the port would go deaf).
        let prt = |baud: u32, in_mask: u8, out_mask: u8| {
            let mut p = [0u8; 20];
            p[0] = 1;
            p[4] = 0xD0;
            p[5] = 0x08;
            p[8..12].copy_from_slice(&baud.to_le_bytes());
            p[12] = in_mask;
            p[14] = out_mask;
            ubx_frame(6, ID_CFG_PRT, &p)
        };
        for (baud, in_mask) in [(0, 3), (38_400, 0), (38_400, 4)] {
            let a = answer(&mut m8, &mut uart, &mut t, &prt(baud, in_mask, 1));
            assert!(contains(&a, &nak(ID_CFG_PRT)), "{baud} {in_mask}");
        }
        assert_eq!((m8.baud(), m8.output()), (Some(9_600), (true, false)));
        assert_eq!(m8.acks_naks(), (0, 5));
        // UBX input only is enough.
        let a = answer(&mut m8, &mut uart, &mut t, &prt(9_600, 1, 1));
        assert!(contains(&a, &ubx_frame(CLASS_ACK, 1, &[CLASS_CFG, ID_CFG_PRT])));
        assert_eq!(m8.output(), (false, false), "NMEA output off, no UBX message on");
        // The shortest measurement period, 25 ms, aligned to Galileo time (timeRef 4), is taken.
        let a =
            answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, ID_CFG_RATE, &[25, 0, 1, 0, 4, 0]));
        assert!(contains(&a, &ubx_frame(CLASS_ACK, 1, &[CLASS_CFG, ID_CFG_RATE])));
        assert_eq!(m8.rate_hz(), 40.0);
        // NAV-PVT on: sent while UBX is an output protocol, not once CFG-PRT leaves NMEA only.
        answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, ID_CFG_MSG, &[1, 7, 1]));
        assert_eq!(m8.output(), (false, true));
        answer(&mut m8, &mut uart, &mut t, &prt(9_600, 1, 2));
        assert_eq!(m8.output(), (true, false));
    }

    #[test]
    fn a_full_transmit_buffer_drops_messages() {
        // NMEA at 10 Hz at 9600 baud: ~1 KB a tenth of a second, far beyond the line's 960 B/s.
        let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 1, 0);
        let mut m8 = UbxGnssModel::factory(rx, Generation::M8, NOON, 0);
        let mut uart = SimUart::new(9_600, 1 << 20);
        let mut t = 0;
        answer(&mut m8, &mut uart, &mut t, &ubx_frame(6, 8, &[100, 0, 1, 0, 1, 0]));
        for _ in 0..300 {
            answer(&mut m8, &mut uart, &mut t, &[]);
        }
        assert!(m8.tx_dropped() > 100, "{}", m8.tx_dropped());
        // What waits never exceeds the buffer: the line is never more than 4096 bytes behind.
        let behind = uart.device_free_at().saturating_sub(t * 1_000_000) / uart.byte_ns();
        assert!(behind <= TX_BUFFER, "{behind}");
    }

    #[test]
    fn the_time_pulse_marks_each_second_from_the_first_fix() {
        // TTFF 26 s from power-up: no edge before 26 s, then one each whole second.
        let rx = || GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 1, 0);
        let gnss = UbxGnssModel::new(rx(), 1, NOON, 0);
        assert_eq!(gnss.pps_at(1), 26 * NS_PER_S);
        assert_eq!(gnss.pps_at(26 * NS_PER_S + 1), 27 * NS_PER_S);
        assert_eq!(gnss.pps_at(40 * NS_PER_S), 40 * NS_PER_S);
        // Powered up at 100.3 s: its first edge at 127 s (126.3 s rounded up to a second).
        let late = UbxGnssModel::new(rx(), 1, NOON, 0).powered_at(100_300_000_000);
        assert_eq!(late.pps_at(0), 127 * NS_PER_S);
    }

    #[test]
    fn a_receiver_powered_later_starts_cold() {
        // Powered up at 100.3 s at 1 Hz: the first epoch at 101 s, no fix until 126.3 s.
        let rx = GnssReceiver::new(GnssParams::UBLOX_M8, ORIGIN, GEOID_M, 1, 0);
        let mut gnss = UbxGnssModel::new(rx, 1, NOON, 0).powered_at(100_300_000_000);
        let seen =
            nav_pvts(&mut gnss, 100_300..140_000, [0.0; 3], [0.0; 3], |p| (p.sec(), p.fix_type()));
        // UTC seconds of the world (NOON + t): 101 s after noon is 12:01:41.
        assert_eq!(seen[0], (41, GnssFixType::NoFix));
        let first_fix = seen.iter().position(|s| s.1 == GnssFixType::Fix3D).unwrap();
        // Epochs at 101..=126 s have no fix (126 s is 25.7 s after power-up); 127 s has one.
        assert_eq!(first_fix, 26, "{seen:?}");
        assert_eq!(seen.len(), 39);
    }
}
