//! u-blox UBX protocol for an external GNSS receiver on a UART (issue 21): a streaming frame
//! decoder that yields UBX-NAV-PVT and UBX-ACK-ACK/NAK, and the configuration the module sends
//! at boot so that the receiver outputs NAV-PVT alone, at a set rate and baud rate.
//!
//! # Sources
//! - u-blox 8 / u-blox M8 Receiver description including protocol specification,
//!   UBX-13003221 (R25), "UBX Protocol" (frame structure, 8-bit Fletcher checksum over class,
//!   id, length and payload), UBX-NAV-PVT (0x01 0x07, 92 bytes), UBX-ACK-ACK (0x05 0x01) and
//!   UBX-ACK-NAK (0x05 0x00), UBX-CFG-PRT (0x06 0x00), UBX-CFG-MSG (0x06 0x01), UBX-CFG-RATE
//!   (0x06 0x08).
//! - u-blox ZED-F9P interface description UBX-18010854 (R04), the generation-9 protocol 27:
//!   §5.14.11 UBX-NAV-PVT (byte offsets of every field read here: pp. 150–151), §5.8 UBX-ACK
//!   (p. 37), §5.9.17.2 CFG-PRT for UART (p. 64), §5.9.12.3 CFG-MSG "set message rate" for the
//!   current port (p. 54), §5.9.19 CFG-RATE (p. 75), §5.9.27 UBX-CFG-VALSET (0x06 0x8A,
//!   version 0: version, layers, 2 reserved bytes, then key IDs and values; pp. 86–87). The
//!   u-blox M9/M10 interface descriptions (e.g. u-blox M10 SPG 5.00, UBX-20053845) carry the
//!   same NAV-PVT and VALSET; M10 has no CFG-PRT/MSG/RATE any more (configuration by keys only).
//! - Configuration keys (interface descriptions, "Configuration reference"): CFG-UART1OUTPROT-
//!   UBX 0x10740001, CFG-UART1OUTPROT-NMEA 0x10740002 (type L), CFG-MSGOUT-UBX_NAV_PVT_UART1
//!   0x20910007 (U1, output every n-th solution), CFG-RATE-MEAS 0x30210001 (U2, ms). Bits 30–28
//!   of a key ID give its value's size (1: one bit stored in a byte, 2: 1 byte, 3: 2, 4: 4,
//!   5: 8). The four IDs are consistent across independent public implementations read for this
//!   (pyubx2's database, several receiver drivers); the PDF's table itself was NOT read here.
//!
//! # Baud rate: what the module does, and why
//! Factory defaults of UART1: **9600 baud on u-blox M8** (NEO-M8 data sheet UBX-13003366 R07,
//! Table 12), **38400 baud on M9 and M10** (NOT VERIFIED: no M9/M10 document was readable here;
//! their CFG-UART1-BAUDRATE default as drivers and users report it).
//! The module runs the link at [`OPERATING_BAUD`] = 38400: NAV-PVT is 100 bytes on the wire,
//! 1000 B/s at 10 Hz, more than 9600 baud carries (960 B/s), and 38400 (3840 B/s) is the
//! generation-9+ default, so an M9/M10 never changes its baud (no acknowledgement lost across a
//! switch, nothing stored in the receiver). At boot the module sends [`boot_config`] once at
//! each rate of [`BOOT_BAUDS`] (38400 first, then 9600), then listens at 38400:
//! - an M9/M10 at 38400 applies the CFG-VALSET (ACK-ACK 0x06 0x8A) and NAKs or ignores the
//!   legacy messages that follow; what it receives at 9600 is noise to it;
//! - an M8 at 9600 ignores the 38400 bytes, then takes CFG-MSG and CFG-RATE (ACKed at 9600) and
//!   CFG-PRT last, which moves it to 38400 — its ACK may be lost in the switch (UBX-18010854
//!   §5.9.17.2 warns of that), so success is judged by NAV-PVT arriving at 38400, not by it;
//! - an M8 already at 38400 (the module reset while the receiver kept power) takes the legacy
//!   messages at 38400.
//!
//! If no NAV-PVT arrives within a few navigation periods the module reports the receiver absent
//! and tries again later; everything else it publishes goes on.
//!
//! # Decoder
//! [`Decoder::push`] takes one byte at a time (a DMA ring buffer's bytes as they come), holds at
//! most one frame (92-byte payload), never panics and never allocates. NMEA sentences and any
//! other bytes between frames are skipped and counted; a frame whose length exceeds the buffer,
//! whose checksum fails, or whose known message has the wrong length is dropped and counted,
//! and the hunt for the next sync starts with the byte after it. A frame that starts inside a
//! bad one (a truncated frame followed at once by the next) is lost with it: at 38400 baud with
//! a DMA ring buffer that needs an overrun, which the UART reports on its own.

/// First sync character.
pub const SYNC1: u8 = 0xB5;
/// Second sync character.
pub const SYNC2: u8 = 0x62;
/// The largest payload the decoder holds: NAV-PVT's.
pub const MAX_PAYLOAD: usize = NAV_PVT_LEN;
/// NAV-PVT's payload length (protocol 15 and later).
pub const NAV_PVT_LEN: usize = 92;
/// Class NAV.
pub const CLASS_NAV: u8 = 0x01;
/// Class ACK.
pub const CLASS_ACK: u8 = 0x05;
/// Class CFG.
pub const CLASS_CFG: u8 = 0x06;
/// NAV-PVT's id.
pub const ID_NAV_PVT: u8 = 0x07;
/// ACK-NAK's id.
pub const ID_ACK_NAK: u8 = 0x00;
/// ACK-ACK's id.
pub const ID_ACK_ACK: u8 = 0x01;
/// CFG-PRT's id.
pub const ID_CFG_PRT: u8 = 0x00;
/// CFG-MSG's id.
pub const ID_CFG_MSG: u8 = 0x01;
/// CFG-RATE's id.
pub const ID_CFG_RATE: u8 = 0x08;
/// CFG-VALSET's id.
pub const ID_CFG_VALSET: u8 = 0x8A;

/// CFG-UART1OUTPROT-UBX (L).
pub const KEY_UART1OUTPROT_UBX: u32 = 0x1074_0001;
/// CFG-UART1OUTPROT-NMEA (L).
pub const KEY_UART1OUTPROT_NMEA: u32 = 0x1074_0002;
/// CFG-MSGOUT-UBX_NAV_PVT_UART1 (U1).
pub const KEY_MSGOUT_UBX_NAV_PVT_UART1: u32 = 0x2091_0007;
/// CFG-RATE-MEAS (U2, ms).
pub const KEY_RATE_MEAS: u32 = 0x3021_0001;

/// The link's baud rate once configured (see the module documentation).
pub const OPERATING_BAUD: u32 = 38_400;
/// The rates at which the module sends [`boot_config`], in order.
pub const BOOT_BAUDS: [u32; 2] = [38_400, 9_600];
/// [`boot_config`]'s length, bytes.
pub const BOOT_CONFIG_LEN: usize = 33 + 11 + 14 + 28;

/// The 8-bit Fletcher checksum (CK_A, CK_B) over `bytes`.
pub fn checksum(bytes: &[u8]) -> [u8; 2] {
    let (mut a, mut b) = (0u8, 0u8);
    for &x in bytes {
        a = a.wrapping_add(x);
        b = b.wrapping_add(a);
    }
    [a, b]
}

/// A UBX-NAV-PVT navigation solution, fields as sent (UBX-18010854 §5.14.11).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NavPvt {
    /// GPS time of week of the epoch, ms.
    pub itow_ms: u32,
    /// UTC year.
    pub year: u16,
    /// UTC month, 1–12.
    pub month: u8,
    /// UTC day, 1–31.
    pub day: u8,
    /// UTC hour, 0–23.
    pub hour: u8,
    /// UTC minute, 0–59.
    pub min: u8,
    /// UTC second, 0–60 (a leap second).
    pub sec: u8,
    /// Validity flags: bit 0 validDate, 1 validTime, 2 fullyResolved.
    pub valid: u8,
    /// Time accuracy, ns.
    pub t_acc_ns: u32,
    /// Fraction of the second, ns (−1e9..1e9).
    pub nano_ns: i32,
    /// 0 none, 1 dead reckoning, 2 2-D, 3 3-D, 4 GNSS + dead reckoning, 5 time only.
    pub fix_type: u8,
    /// Fix status flags: bit 0 gnssFixOK.
    pub flags: u8,
    /// Satellites used.
    pub num_sv: u8,
    /// Longitude, 1e-7 degree.
    pub lon_e7: i32,
    /// Latitude, 1e-7 degree.
    pub lat_e7: i32,
    /// Height above the ellipsoid, mm.
    pub height_mm: i32,
    /// Height above mean sea level, mm.
    pub hmsl_mm: i32,
    /// Horizontal accuracy, mm.
    pub h_acc_mm: u32,
    /// Vertical accuracy, mm.
    pub v_acc_mm: u32,
    /// Velocity north, mm/s.
    pub vel_n_mm_s: i32,
    /// Velocity east, mm/s.
    pub vel_e_mm_s: i32,
    /// Velocity down, mm/s.
    pub vel_d_mm_s: i32,
    /// Ground speed (2-D), mm/s.
    pub g_speed_mm_s: i32,
    /// Heading of motion (2-D), 1e-5 degree.
    pub head_mot_e5: i32,
    /// Speed accuracy, mm/s.
    pub s_acc_mm_s: u32,
    /// Heading accuracy, 1e-5 degree.
    pub head_acc_e5: u32,
    /// Position DOP, 0.01.
    pub p_dop: u16,
}

impl NavPvt {
    /// Decodes a NAV-PVT payload; `None` unless it has 92 bytes.
    pub fn from_payload(p: &[u8]) -> Option<NavPvt> {
        if p.len() != NAV_PVT_LEN {
            return None;
        }
        let u32_at = |i: usize| u32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]);
        let i32_at = |i: usize| u32_at(i) as i32;
        Some(NavPvt {
            itow_ms: u32_at(0),
            year: u16::from_le_bytes([p[4], p[5]]),
            month: p[6],
            day: p[7],
            hour: p[8],
            min: p[9],
            sec: p[10],
            valid: p[11],
            t_acc_ns: u32_at(12),
            nano_ns: i32_at(16),
            fix_type: p[20],
            flags: p[21],
            num_sv: p[23],
            lon_e7: i32_at(24),
            lat_e7: i32_at(28),
            height_mm: i32_at(32),
            hmsl_mm: i32_at(36),
            h_acc_mm: u32_at(40),
            v_acc_mm: u32_at(44),
            vel_n_mm_s: i32_at(48),
            vel_e_mm_s: i32_at(52),
            vel_d_mm_s: i32_at(56),
            g_speed_mm_s: i32_at(60),
            head_mot_e5: i32_at(64),
            s_acc_mm_s: u32_at(68),
            head_acc_e5: u32_at(72),
            p_dop: u16::from_le_bytes([p[76], p[77]]),
        })
    }

    /// gnssFixOK: the fix is within the receiver's DOP and accuracy masks.
    pub fn gnss_fix_ok(&self) -> bool {
        self.flags & 1 != 0
    }

    /// The UTC date is valid.
    pub fn valid_date(&self) -> bool {
        self.valid & 1 != 0
    }

    /// The UTC time of day is valid.
    pub fn valid_time(&self) -> bool {
        self.valid & 2 != 0
    }

    /// The UTC time of day is fully resolved (no seconds uncertainty).
    pub fn fully_resolved(&self) -> bool {
        self.valid & 4 != 0
    }
}

/// A frame the decoder recognised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Message {
    /// UBX-NAV-PVT.
    NavPvt(NavPvt),
    /// UBX-ACK-ACK for the configuration message (class, id).
    Ack(u8, u8),
    /// UBX-ACK-NAK for the configuration message (class, id).
    Nak(u8, u8),
    /// Another well-formed frame (class, id), its payload not kept.
    Other(u8, u8),
}

/// The decoder's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Frames with a good checksum.
    pub frames: u32,
    /// Frames dropped for their checksum.
    pub checksum_errors: u32,
    /// Frames dropped for their length: longer than [`MAX_PAYLOAD`] (a corrupted length or a
    /// message this decoder does not keep) or wrong for NAV-PVT or ACK.
    pub length_errors: u32,
    /// Bytes outside good frames (NMEA, noise, dropped frames).
    pub dropped_bytes: u32,
}

/// The longest frame the decoder holds: sync, class, id, length, NAV-PVT's payload, checksum.
pub const MAX_FRAME: usize = MAX_PAYLOAD + 8;

/// Byte-at-a-time UBX frame decoder; see the module documentation.
#[derive(Clone, Debug)]
pub struct Decoder {
    /// The frame so far: `buf[..pos]`.
    buf: [u8; MAX_FRAME],
    pos: u8,
    stats: Stats,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            pos: 0,
            stats: Stats { frames: 0, checksum_errors: 0, length_errors: 0, dropped_bytes: 0 },
        }
    }

    /// Counters so far.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// Bytes of a frame held (received, not yet complete).
    pub fn held(&self) -> usize {
        usize::from(self.pos)
    }

    /// The payload length the frame in progress declares (its header must be in).
    fn len(&self) -> usize {
        usize::from(u16::from_le_bytes([self.buf[4], self.buf[5]]))
    }

    /// Drops the frame in progress, its bytes counted (wrapping: counters of a receiver that
    /// runs for years, never a panic).
    fn drop_frame(&mut self) -> Option<Message> {
        self.stats.dropped_bytes = self.stats.dropped_bytes.wrapping_add(u32::from(self.pos));
        self.pos = 0;
        None
    }

    /// Takes one byte; returns the message this byte completes, if any.
    pub fn push(&mut self, byte: u8) -> Option<Message> {
        let sync = match self.pos {
            0 => SYNC1,
            1 => SYNC2,
            _ => byte,
        };
        if byte != sync {
            // 0xB5 0xB5 0x62: the second 0xB5 may start the frame.
            if byte == SYNC1 {
                self.stats.dropped_bytes = self.stats.dropped_bytes.wrapping_add(1);
                return None;
            }
            self.pos += 1;
            return self.drop_frame();
        }
        self.buf[usize::from(self.pos)] = byte;
        self.pos += 1;
        let pos = usize::from(self.pos);
        if pos < 6 {
            return None;
        }
        let len = self.len();
        if len > MAX_PAYLOAD {
            self.stats.length_errors = self.stats.length_errors.wrapping_add(1);
            return self.drop_frame();
        }
        if pos < len + 8 {
            return None;
        }
        if checksum(&self.buf[2..6 + len]) != [self.buf[6 + len], self.buf[7 + len]] {
            self.stats.checksum_errors = self.stats.checksum_errors.wrapping_add(1);
            return self.drop_frame();
        }
        let [class, id] = [self.buf[2], self.buf[3]];
        let payload = &self.buf[6..6 + len];
        let m = match (class, id, len) {
            (CLASS_NAV, ID_NAV_PVT, _) => NavPvt::from_payload(payload).map(Message::NavPvt),
            (CLASS_ACK, ID_ACK_ACK, 2) => Some(Message::Ack(payload[0], payload[1])),
            (CLASS_ACK, ID_ACK_NAK, 2) => Some(Message::Nak(payload[0], payload[1])),
            (CLASS_ACK, ID_ACK_ACK | ID_ACK_NAK, _) => None,
            _ => Some(Message::Other(class, id)),
        };
        if m.is_none() {
            self.stats.length_errors = self.stats.length_errors.wrapping_add(1);
            return self.drop_frame();
        }
        self.stats.frames = self.stats.frames.wrapping_add(1);
        self.pos = 0;
        m
    }
}

/// An encoding error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// The output buffer holds fewer bytes than the frame needs (`needed`).
    BufferTooSmall {
        /// Bytes the frame needs.
        needed: usize,
    },
    /// A configuration key whose value size is not 1, 2 or 4 bytes (bits 30–28 of the key).
    KeySize(u32),
    /// A navigation rate outside 1–10 Hz.
    Rate(u8),
    /// More key-value pairs than one CFG-VALSET carries ([`VALSET_MAX_ITEMS`]).
    TooManyItems(usize),
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::BufferTooSmall { needed } => {
                write!(f, "UBX frame needs {needed} bytes, the buffer is smaller")
            }
            Error::KeySize(k) => {
                write!(f, "configuration key {k:#010x}: value size not 1, 2 or 4 bytes")
            }
            Error::Rate(hz) => write!(f, "navigation rate {hz} Hz outside 1–10 Hz"),
            Error::TooManyItems(n) => {
                write!(f, "{n} configuration items, one CFG-VALSET carries {VALSET_MAX_ITEMS}")
            }
        }
    }
}

/// Writes one frame (sync, class, id, length, `payload`, checksum) at the start of `out`;
/// returns its length.
pub fn encode(class: u8, id: u8, payload: &[u8], out: &mut [u8]) -> Result<usize, Error> {
    let n = payload.len() + 8;
    let Some(f) = out.get_mut(..n) else { return Err(Error::BufferTooSmall { needed: n }) };
    let [l0, l1] = (payload.len() as u16).to_le_bytes();
    f[..6].copy_from_slice(&[SYNC1, SYNC2, class, id, l0, l1]);
    f[6..n - 2].copy_from_slice(payload);
    seal(f);
    Ok(n)
}

/// A key's value size in bytes, from bits 30–28 of its ID (one-bit L values take a byte).
pub fn key_value_size(key: u32) -> Result<usize, Error> {
    match (key >> 28) & 7 {
        1 | 2 => Ok(1),
        3 => Ok(2),
        4 => Ok(4),
        _ => Err(Error::KeySize(key)),
    }
}

/// Most key-value pairs one CFG-VALSET carries (UBX-18010854 §5.9.27: "limited to containing
/// a maximum of 64 key-value pairs").
pub const VALSET_MAX_ITEMS: usize = 64;

/// UBX-CFG-VALSET, version 0 (applied at once), to the `layers` (bit 0 RAM, 1 BBR, 2 flash):
/// each `(key, value)` with the value's low bytes in the key's size.
pub fn cfg_valset(layers: u8, items: &[(u32, u32)], out: &mut [u8]) -> Result<usize, Error> {
    if items.len() > VALSET_MAX_ITEMS {
        return Err(Error::TooManyItems(items.len()));
    }
    let mut len = 4;
    for &(key, _) in items {
        len += 4 + key_value_size(key)?;
    }
    let n = len + 8;
    let Some(f) = out.get_mut(..n) else { return Err(Error::BufferTooSmall { needed: n }) };
    let [l0, l1] = (len as u16).to_le_bytes();
    f[..10].copy_from_slice(&[SYNC1, SYNC2, CLASS_CFG, ID_CFG_VALSET, l0, l1, 0, layers, 0, 0]);
    let mut at = 10;
    for &(key, value) in items {
        let size = key_value_size(key)?;
        f[at..at + 4].copy_from_slice(&key.to_le_bytes());
        f[at + 4..at + 4 + size].copy_from_slice(&value.to_le_bytes()[..size]);
        at += 4 + size;
    }
    seal(f);
    Ok(n)
}

/// UBX-CFG-PRT for UART1 (port 1): 8N1 at `baud`, input UBX and NMEA, output UBX only.
pub fn cfg_prt_uart1(baud: u32, out: &mut [u8]) -> Result<usize, Error> {
    let mut p = [0u8; 20];
    p[0] = 1; // portID: UART1
              // mode: charLen 8 bit (bits 7–6 = 11), parity none (bits 11–9 = 100), 1 stop bit (13–12 =
              // 00), bit 4 set as the receivers' own default (0x000008D0).
    p[4..8].copy_from_slice(&0x0000_08D0u32.to_le_bytes());
    p[8..12].copy_from_slice(&baud.to_le_bytes());
    p[12] = 0x03; // inProtoMask: UBX, NMEA
    p[14] = 0x01; // outProtoMask: UBX
    encode(CLASS_CFG, ID_CFG_PRT, &p, out)
}

/// UBX-CFG-MSG, 3-byte form: `class`/`id` every `rate` navigation solutions on the port that
/// receives it.
pub fn cfg_msg(class: u8, id: u8, rate: u8, out: &mut [u8]) -> Result<usize, Error> {
    encode(CLASS_CFG, ID_CFG_MSG, &[class, id, rate], out)
}

/// UBX-CFG-RATE: a measurement every `meas_ms`, a solution every measurement, aligned to GPS
/// time.
pub fn cfg_rate(meas_ms: u16, out: &mut [u8]) -> Result<usize, Error> {
    let [m0, m1] = meas_ms.to_le_bytes();
    encode(CLASS_CFG, ID_CFG_RATE, &[m0, m1, 1, 0, 1, 0], out)
}

/// Writes the frame (`class`, `id`, `payload`) into `buf` at `at`, at compile time.
const fn put_frame(buf: &mut [u8; BOOT_CONFIG_LEN], at: usize, class: u8, id: u8, payload: &[u8]) {
    let n = payload.len();
    assert!(n < 256, "the boot frames' lengths fit their low byte");
    let head = [SYNC1, SYNC2, class, id, n as u8, 0];
    let mut i = 0;
    while i < 6 + n {
        buf[at + i] = if i < 6 { head[i] } else { payload[i - 6] };
        i += 1;
    }
}

/// Byte offsets in [`boot_config`]'s output: the frames, and the two copies of the
/// measurement period (CFG-VALSET's CFG-RATE-MEAS value, CFG-RATE's measRate).
const VALSET_AT: usize = 0;
const MSG_AT: usize = 33;
const RATE_AT: usize = 44;
const PRT_AT: usize = 58;
const VALSET_MEAS_AT: usize = VALSET_AT + 6 + 4 + 3 * 5 + 4;
const RATE_MEAS_AT: usize = RATE_AT + 6;

/// [`boot_config`] at 1 Hz without its checksums, built at compile time: the image holds these
/// 86 bytes and patches the period and two checksums rather than linking the encoders.
const BOOT_TEMPLATE: [u8; BOOT_CONFIG_LEN] = {
    let mut b = [0u8; BOOT_CONFIG_LEN];
    let (nmea, ubx, pvt, meas) = (
        KEY_UART1OUTPROT_NMEA.to_le_bytes(),
        KEY_UART1OUTPROT_UBX.to_le_bytes(),
        KEY_MSGOUT_UBX_NAV_PVT_UART1.to_le_bytes(),
        KEY_RATE_MEAS.to_le_bytes(),
    );
    #[rustfmt::skip]
    let valset = [
        0, 1, 0, 0, // version 0, layers: RAM
        nmea[0], nmea[1], nmea[2], nmea[3], 0,
        ubx[0], ubx[1], ubx[2], ubx[3], 1,
        pvt[0], pvt[1], pvt[2], pvt[3], 1,
        meas[0], meas[1], meas[2], meas[3], 0, 0,
    ];
    put_frame(&mut b, VALSET_AT, CLASS_CFG, ID_CFG_VALSET, &valset);
    put_frame(&mut b, MSG_AT, CLASS_CFG, ID_CFG_MSG, &[CLASS_NAV, ID_NAV_PVT, 1]);
    put_frame(&mut b, RATE_AT, CLASS_CFG, ID_CFG_RATE, &[0, 0, 1, 0, 1, 0]);
    let baud = OPERATING_BAUD.to_le_bytes();
    #[rustfmt::skip]
    let prt = [
        1, 0, 0, 0, // UART1, reserved, txReady off
        0xD0, 0x08, 0, 0, // mode: 8N1 (see cfg_prt_uart1)
        baud[0], baud[1], baud[2], baud[3],
        0x03, 0, 0x01, 0, // in UBX + NMEA, out UBX
        0, 0, 0, 0,
    ];
    put_frame(&mut b, PRT_AT, CLASS_CFG, ID_CFG_PRT, &prt);
    b
};

/// Sets the checksum of the whole frame `f`.
fn seal(f: &mut [u8]) {
    let n = f.len();
    let ck = checksum(&f[2..n - 2]);
    f[n - 2..].copy_from_slice(&ck);
}

/// Everything the module sends at boot for NAV-PVT on UART1 at `rate_hz` (1–10) and no NMEA,
/// [`BOOT_CONFIG_LEN`] bytes: CFG-VALSET to RAM (M9/M10: UART1 NMEA output off, UBX on, NAV-PVT
/// every solution, CFG-RATE-MEAS), then CFG-MSG (NAV-PVT every solution), CFG-RATE and CFG-PRT
/// to [`OPERATING_BAUD`], input UBX + NMEA, output UBX (M8; CFG-PRT last, as it changes the
/// baud). The same bytes as [`cfg_valset`], [`cfg_msg`], [`cfg_rate`] and [`cfg_prt_uart1`]
/// (tested), from a compile-time template. Send it at each rate of [`BOOT_BAUDS`]; see the
/// module documentation.
pub fn boot_config(rate_hz: u8, out: &mut [u8]) -> Result<usize, Error> {
    if !(1..=10).contains(&rate_hz) {
        return Err(Error::Rate(rate_hz));
    }
    let Some(out) = out.get_mut(..BOOT_CONFIG_LEN) else {
        return Err(Error::BufferTooSmall { needed: BOOT_CONFIG_LEN });
    };
    out.copy_from_slice(&BOOT_TEMPLATE);
    let meas = (1000 / u16::from(rate_hz)).to_le_bytes();
    out[VALSET_MEAS_AT..VALSET_MEAS_AT + 2].copy_from_slice(&meas);
    out[RATE_MEAS_AT..RATE_MEAS_AT + 2].copy_from_slice(&meas);
    for f in [VALSET_AT..MSG_AT, MSG_AT..RATE_AT, RATE_AT..PRT_AT, PRT_AT..BOOT_CONFIG_LEN] {
        seal(&mut out[f]);
    }
    Ok(BOOT_CONFIG_LEN)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    fn frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
        let mut out = std::vec![0u8; payload.len() + 8];
        assert_eq!(encode(class, id, payload, &mut out), Ok(payload.len() + 8));
        out
    }

    fn pvt_payload() -> [u8; NAV_PVT_LEN] {
        let mut p = [0u8; NAV_PVT_LEN];
        for (i, b) in p.iter_mut().enumerate() {
            *b = (i as u8).wrapping_mul(37).wrapping_add(11);
        }
        p
    }

    fn decode_all(bytes: &[u8]) -> (Vec<Message>, Stats) {
        let mut d = Decoder::new();
        let m = bytes.iter().filter_map(|&b| d.push(b)).collect();
        (m, d.stats())
    }

    #[test]
    fn checksum_of_the_ack_for_cfg_msg() {
        // ACK-ACK for CFG-MSG as receivers send it: B5 62 05 01 02 00 06 01 0F 38.
        assert_eq!(
            frame(CLASS_ACK, ID_ACK_ACK, &[0x06, 0x01]),
            [0xB5, 0x62, 0x05, 0x01, 0x02, 0x00, 0x06, 0x01, 0x0F, 0x38]
        );
    }

    #[test]
    fn nav_pvt_fields_at_their_offsets() {
        let mut p = [0u8; NAV_PVT_LEN];
        let put =
            |p: &mut [u8; NAV_PVT_LEN], at: usize, b: &[u8]| p[at..at + b.len()].copy_from_slice(b);
        put(&mut p, 0, &475_218_200u32.to_le_bytes());
        put(&mut p, 4, &2026u16.to_le_bytes());
        put(&mut p, 6, &[11, 27, 12, 34, 56, 0x07]);
        put(&mut p, 12, &30u32.to_le_bytes());
        put(&mut p, 16, &(-123_456i32).to_le_bytes());
        put(&mut p, 20, &[3, 0x01, 0xEE, 12]);
        put(&mut p, 24, &92_270_000i32.to_le_bytes());
        put(&mut p, 28, &(-454_780_000i32).to_le_bytes());
        put(&mut p, 32, &170_500i32.to_le_bytes());
        put(&mut p, 36, &123_500i32.to_le_bytes());
        put(&mut p, 40, &1_000u32.to_le_bytes());
        put(&mut p, 44, &2_000u32.to_le_bytes());
        put(&mut p, 48, &400i32.to_le_bytes());
        put(&mut p, 52, &300i32.to_le_bytes());
        put(&mut p, 56, &(-5i32).to_le_bytes());
        put(&mut p, 60, &500i32.to_le_bytes());
        put(&mut p, 64, &3_686_990i32.to_le_bytes());
        put(&mut p, 68, &500u32.to_le_bytes());
        put(&mut p, 72, &18_000_000u32.to_le_bytes());
        put(&mut p, 76, &120u16.to_le_bytes());
        let (m, st) = decode_all(&frame(CLASS_NAV, ID_NAV_PVT, &p));
        let want = NavPvt {
            itow_ms: 475_218_200,
            year: 2026,
            month: 11,
            day: 27,
            hour: 12,
            min: 34,
            sec: 56,
            valid: 7,
            t_acc_ns: 30,
            nano_ns: -123_456,
            fix_type: 3,
            flags: 1,
            num_sv: 12,
            lon_e7: 92_270_000,
            lat_e7: -454_780_000,
            height_mm: 170_500,
            hmsl_mm: 123_500,
            h_acc_mm: 1_000,
            v_acc_mm: 2_000,
            vel_n_mm_s: 400,
            vel_e_mm_s: 300,
            vel_d_mm_s: -5,
            g_speed_mm_s: 500,
            head_mot_e5: 3_686_990,
            s_acc_mm_s: 500,
            head_acc_e5: 18_000_000,
            p_dop: 120,
        };
        assert_eq!(m, [Message::NavPvt(want)]);
        assert_eq!(st, Stats { frames: 1, ..Stats::default() });
        assert!(want.gnss_fix_ok() && want.valid_date() && want.valid_time());
        assert!(want.fully_resolved());
        let none = NavPvt::default();
        assert!(!none.gnss_fix_ok() && !none.valid_date() && !none.valid_time());
        assert!(!none.fully_resolved());
        let only = |valid, flags| NavPvt { valid, flags, ..none };
        assert!(only(2, 0).valid_time() && !only(2, 0).valid_date());
        assert!(!only(2, 0).fully_resolved() && only(4, 0).fully_resolved());
        assert!(only(0, 1).gnss_fix_ok() && !only(0, 2).gnss_fix_ok());
    }

    #[test]
    fn skips_nmea_between_frames_and_counts_it() {
        let nmea = b"$GNGGA,120000.00,4528.68,N,00913.62,E,1,12,1.2,170.0,M,47.0,M,,*4F\r\n";
        let mut s = nmea.to_vec();
        s.extend(frame(CLASS_NAV, ID_NAV_PVT, &pvt_payload()));
        s.extend(nmea);
        s.extend(frame(CLASS_ACK, ID_ACK_ACK, &[0x06, 0x8A]));
        s.extend(frame(CLASS_ACK, ID_ACK_NAK, &[0x06, 0x00]));
        s.extend(frame(0x0A, 0x04, b"ROM CORE 3.01"));
        s.extend(frame(0x0A, 0x09, &[]));
        let (m, st) = decode_all(&s);
        assert_eq!(m.len(), 5);
        assert_eq!(m[0], Message::NavPvt(NavPvt::from_payload(&pvt_payload()).unwrap()));
        assert_eq!(
            m[1..],
            [
                Message::Ack(0x06, 0x8A),
                Message::Nak(0x06, 0x00),
                Message::Other(0x0A, 0x04),
                Message::Other(0x0A, 0x09)
            ]
        );
        assert_eq!(st, Stats { frames: 5, dropped_bytes: 2 * nmea.len() as u32, ..st });
        assert_eq!((st.checksum_errors, st.length_errors), (0, 0));
    }

    #[test]
    fn repeated_first_sync_and_broken_sync() {
        let ack = frame(CLASS_ACK, ID_ACK_ACK, &[6, 1]);
        let mut s = std::vec![SYNC1, SYNC1, 0x00, SYNC1];
        s.extend(&ack);
        let (m, st) = decode_all(&s);
        assert_eq!(m, [Message::Ack(6, 1)]);
        // 0xB5 (another follows), 0xB5 0x00 (a broken pair: both), the 0xB5 before the frame's.
        assert_eq!(st.dropped_bytes, 4);
    }

    #[test]
    fn bad_checksums_and_lengths_are_counted_and_dropped() {
        let good = frame(CLASS_NAV, ID_NAV_PVT, &pvt_payload());
        let mut bad_a = good.clone();
        bad_a[98] ^= 0x10;
        let mut bad_b = good.clone();
        bad_b[99] ^= 0x01;
        let mut bad_payload = good.clone();
        bad_payload[40] ^= 0x80;
        // Length 0xFFFF: oversize, dropped after its 6 header bytes.
        let oversize = [SYNC1, SYNC2, 0x01, 0x07, 0xFF, 0xFF];
        // A NAV-PVT of 84 bytes (u-blox 7's) and an ACK of 3: good checksums, wrong lengths.
        let short_pvt = frame(CLASS_NAV, ID_NAV_PVT, &[0u8; 84]);
        let long_ack = frame(CLASS_ACK, ID_ACK_ACK, &[6, 1, 0]);
        let short_nak = frame(CLASS_ACK, ID_ACK_NAK, &[6]);
        let mut s = Vec::new();
        for part in [&bad_a[..], &bad_b, &bad_payload, &oversize, &short_pvt, &long_ack, &short_nak]
        {
            s.extend(part);
            s.extend(&good);
        }
        let (m, st) = decode_all(&s);
        assert_eq!(m.len(), 7);
        assert!(m.iter().all(|x| matches!(x, Message::NavPvt(_))));
        assert_eq!(st.frames, 7);
        assert_eq!(st.checksum_errors, 3);
        assert_eq!(st.length_errors, 4);
        let dropped = 3 * 100 + 6 + short_pvt.len() + long_ack.len() + short_nak.len();
        assert_eq!(st.dropped_bytes as usize, dropped);
    }

    #[test]
    fn the_longest_payload_fits_and_one_more_byte_does_not() {
        let ok = frame(0x01, 0x99, &[0x55; MAX_PAYLOAD]);
        let over = frame(0x01, 0x99, &[0x55; MAX_PAYLOAD + 1]);
        let (m, st) = decode_all(&[&over[..], &ok].concat());
        assert_eq!(m, [Message::Other(0x01, 0x99)]);
        assert_eq!(st.length_errors, 1);
        // The oversize frame's header is dropped, then its payload is hunted through (0x55s).
        assert_eq!(st.dropped_bytes as usize, over.len());
    }

    #[test]
    fn empty_payload_frames() {
        let (m, st) = decode_all(&frame(0x0A, 0x04, &[]));
        assert_eq!(m, [Message::Other(0x0A, 0x04)]);
        assert_eq!(st, Stats { frames: 1, ..Stats::default() });
    }

    #[test]
    fn encode_refuses_a_short_buffer() {
        let mut out = [0u8; 9];
        assert_eq!(encode(6, 1, &[1, 2], &mut out), Err(Error::BufferTooSmall { needed: 10 }));
        assert_eq!(encode(6, 1, &[1], &mut out), Ok(9));
        assert_eq!(
            boot_config(5, &mut [0u8; BOOT_CONFIG_LEN - 1]),
            Err(Error::BufferTooSmall { needed: BOOT_CONFIG_LEN })
        );
    }

    #[test]
    fn key_sizes_from_their_ids() {
        assert_eq!(key_value_size(KEY_UART1OUTPROT_NMEA), Ok(1));
        assert_eq!(key_value_size(KEY_MSGOUT_UBX_NAV_PVT_UART1), Ok(1));
        assert_eq!(key_value_size(KEY_RATE_MEAS), Ok(2));
        assert_eq!(key_value_size(0x4052_0001), Ok(4)); // CFG-UART1-BAUDRATE
        assert_eq!(key_value_size(0x5000_0001), Err(Error::KeySize(0x5000_0001)));
        assert_eq!(key_value_size(0x0000_0001), Err(Error::KeySize(1)));
        let mut out = [0u8; 64];
        assert_eq!(cfg_valset(1, &[(0x5000_0001, 0)], &mut out), Err(Error::KeySize(0x5000_0001)));
    }

    #[test]
    fn valset_bytes() {
        let mut out = [0u8; 64];
        let n = cfg_valset(1, &[(KEY_RATE_MEAS, 200), (0x4052_0001, 38_400)], &mut out).unwrap();
        assert_eq!(out[..6], [0xB5, 0x62, 0x06, 0x8A, 4 + 6 + 8, 0]);
        assert_eq!(out[6..10], [0, 1, 0, 0]);
        assert_eq!(out[10..16], [0x01, 0x00, 0x21, 0x30, 200, 0]);
        assert_eq!(out[16..24], [0x01, 0x00, 0x52, 0x40, 0x00, 0x96, 0x00, 0x00]);
        assert_eq!(n, 8 + 18);
        assert_eq!(out[n - 2..n], checksum(&out[2..n - 2]));
    }

    #[test]
    fn boot_config_frames() {
        let mut out = [0u8; 128];
        let n = boot_config(5, &mut out).unwrap();
        assert_eq!(n, BOOT_CONFIG_LEN);
        let (m, st) = decode_all(&out[..n]);
        assert_eq!(
            m,
            [
                Message::Other(CLASS_CFG, ID_CFG_VALSET),
                Message::Other(CLASS_CFG, ID_CFG_MSG),
                Message::Other(CLASS_CFG, ID_CFG_RATE),
                Message::Other(CLASS_CFG, ID_CFG_PRT)
            ]
        );
        assert_eq!(st.dropped_bytes, 0);
        // VALSET: NMEA off, UBX on, NAV-PVT every solution, 200 ms.
        assert_eq!(out[6..10], [0, 1, 0, 0]);
        assert_eq!(
            out[10..31],
            [
                0x02, 0x00, 0x74, 0x10, 0, 0x01, 0x00, 0x74, 0x10, 1, 0x07, 0x00, 0x91, 0x20, 1,
                0x01, 0x00, 0x21, 0x30, 200, 0
            ]
        );
        // CFG-MSG NAV-PVT 1, CFG-RATE 200 ms / 1 / GPS.
        assert_eq!(out[33 + 6..33 + 9], [0x01, 0x07, 1]);
        assert_eq!(out[44 + 6..44 + 12], [200, 0, 1, 0, 1, 0]);
        // CFG-PRT: UART1, 8N1, 38400, in UBX+NMEA, out UBX.
        assert_eq!(
            out[58 + 6..58 + 26],
            [1, 0, 0, 0, 0xD0, 0x08, 0, 0, 0x00, 0x96, 0, 0, 3, 0, 1, 0, 0, 0, 0, 0]
        );
        assert_eq!(boot_config(0, &mut out), Err(Error::Rate(0)));
        assert_eq!(boot_config(11, &mut out), Err(Error::Rate(11)));
        boot_config(10, &mut out).unwrap();
        assert_eq!(out[10 + 15..10 + 21], [0x01, 0x00, 0x21, 0x30, 100, 0]);
        boot_config(1, &mut out).unwrap();
        assert_eq!(out[44 + 6..44 + 8], 1000u16.to_le_bytes());
    }

    #[test]
    fn boot_config_is_the_encoders_output_at_every_rate() {
        for hz in 1..=10u8 {
            let meas = 1000 / u16::from(hz);
            let mut want = [0u8; 256];
            let items = [
                (KEY_UART1OUTPROT_NMEA, 0),
                (KEY_UART1OUTPROT_UBX, 1),
                (KEY_MSGOUT_UBX_NAV_PVT_UART1, 1),
                (KEY_RATE_MEAS, u32::from(meas)),
            ];
            let mut n = cfg_valset(1, &items, &mut want).unwrap();
            n += cfg_msg(CLASS_NAV, ID_NAV_PVT, 1, &mut want[n..]).unwrap();
            n += cfg_rate(meas, &mut want[n..]).unwrap();
            n += cfg_prt_uart1(OPERATING_BAUD, &mut want[n..]).unwrap();
            let mut got = [0u8; BOOT_CONFIG_LEN];
            assert_eq!(boot_config(hz, &mut got), Ok(n));
            assert_eq!(got[..], want[..n], "{hz} Hz");
        }
    }

    #[test]
    fn valset_limits() {
        let mut out = [0u8; 600];
        let items = [(0x4052_0001u32, 0x0102_0304u32); VALSET_MAX_ITEMS + 1];
        assert_eq!(cfg_valset(1, &items, &mut out), Err(Error::TooManyItems(65)));
        // 64 four-byte values: 4 + 64 × 8 = 516 bytes of payload, a two-byte length.
        let n = cfg_valset(1, &items[..64], &mut out).unwrap();
        assert_eq!((n, out[4], out[5]), (524, 0x04, 0x02));
        assert_eq!(out[n - 10..n - 2], [0x01, 0x00, 0x52, 0x40, 0x04, 0x03, 0x02, 0x01]);
        assert_eq!(
            cfg_valset(1, &items[..64], &mut out[..523]),
            Err(Error::BufferTooSmall { needed: 524 })
        );
        let (m, st) = decode_all(&out[..n]);
        assert_eq!((m.len(), st.length_errors), (0, 1), "longer than the decoder keeps");
        assert_eq!(cfg_valset(2, &[], &mut out), Ok(12));
        assert_eq!(out[..12], frame(CLASS_CFG, ID_CFG_VALSET, &[0, 2, 0, 0])[..]);
    }

    #[test]
    fn the_decoder_is_one_frame_of_ram() {
        assert_eq!(MAX_FRAME, 100);
        assert!(core::mem::size_of::<Decoder>() <= MAX_FRAME + 24);
    }

    #[test]
    fn errors_display() {
        assert!(std::format!("{}", Error::TooManyItems(65)).contains("65"));
        assert!(std::format!("{}", Error::Rate(11)).contains("11 Hz"));
        assert!(std::format!("{}", Error::KeySize(0x5000_0001)).contains("0x50000001"));
        assert!(std::format!("{}", Error::BufferTooSmall { needed: 86 }).contains("86"));
    }

    proptest! {
        /// Any bytes: no panic, and every byte is in a good frame, dropped, or still held.
        #[test]
        fn any_bytes_never_panic_and_balance(bytes in proptest::collection::vec(any::<u8>(), 0..800)) {
            let mut d = Decoder::new();
            let mut in_frames = 0usize;
            for &b in &bytes {
                let before = d.held();
                if d.push(b).is_some() {
                    in_frames += before + 1;
                }
            }
            let held = d.held();
            prop_assert_eq!(in_frames + d.stats().dropped_bytes as usize + held, bytes.len());
        }

        /// Good frames between NMEA-like noise free of 0xB5 all come through, in order.
        #[test]
        fn frames_between_noise_all_decode(
            parts in proptest::collection::vec(
                (any::<[u8; 16]>(), proptest::collection::vec(0u8..0xB5, 0..40)), 1..12)
        ) {
            let mut s = Vec::new();
            let mut want = Vec::new();
            for (seed, junk) in &parts {
                s.extend(junk);
                let mut p = pvt_payload();
                p[..16].copy_from_slice(seed);
                s.extend(frame(CLASS_NAV, ID_NAV_PVT, &p));
                want.push(Message::NavPvt(NavPvt::from_payload(&p).unwrap()));
            }
            let (m, st) = decode_all(&s);
            prop_assert_eq!(m, want);
            prop_assert_eq!(st.checksum_errors + st.length_errors, 0);
        }

        /// One bit flipped anywhere in a frame: that frame is never returned with other
        /// contents (the checksum or a length check catches it), and the frame after it decodes.
        #[test]
        fn a_bit_flip_never_yields_a_wrong_frame(at in 0usize..100, bit in 0u8..8) {
            let good = frame(CLASS_NAV, ID_NAV_PVT, &pvt_payload());
            let mut bad = good.clone();
            bad[at] ^= 1 << bit;
            let (m, _) = decode_all(&[&bad[..], &good].concat());
            let want = Message::NavPvt(NavPvt::from_payload(&pvt_payload()).unwrap());
            prop_assert!(!m.is_empty() && m.iter().all(|x| *x == want), "{:?}", m);
        }

        /// A frame cut short anywhere, then a good one: the good one decodes unless the cut
        /// frame's remaining length swallowed its start; nothing else is returned.
        #[test]
        fn truncated_frames_are_dropped(cut in 1usize..100) {
            let good = frame(CLASS_NAV, ID_NAV_PVT, &pvt_payload());
            let s = [&good[..cut], &good, &good].concat();
            let (m, st) = decode_all(&s);
            let want = Message::NavPvt(NavPvt::from_payload(&pvt_payload()).unwrap());
            prop_assert!(m.iter().all(|x| *x == want));
            prop_assert!(!m.is_empty(), "the third frame always decodes");
            prop_assert_eq!(st.frames as usize, m.len());
        }
    }
}
