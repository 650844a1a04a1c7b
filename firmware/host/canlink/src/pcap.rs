//! pcap capture files with the SocketCAN link type (`LINKTYPE_CAN_SOCKETCAN`, 227), which
//! Wireshark, tshark and tcpdump decode as CAN.
//!
//! File layout (<https://www.tcpdump.org/linktypes/LINKTYPE_CAN_SOCKETCAN.html> and the
//! classic pcap format):
//!
//! | part | bytes | content |
//! |---|---|---|
//! | global header | 24 | magic `A1B2C3D4` (µs timestamps), version 2.4, zone 0, sigfigs 0, snaplen, link type 227 |
//! | record header | 16 | seconds, microseconds, captured length, original length |
//! | CAN ID and flags | 4 | **big-endian** (network order): 29/11-bit ID, `0x8000_0000` extended, `0x4000_0000` remote, `0x2000_0000` error |
//! | payload length | 1 | 0–8 |
//! | padding, reserved | 3 | zero |
//! | payload | 8 | the data, zero-padded to 8 bytes (as a Linux capture of a `struct can_frame`) |
//!
//! The writer writes the headers little-endian, as a little-endian machine does; the reader
//! takes either byte order and microsecond or nanosecond files. The CAN ID field is big-endian
//! in both (it is part of the packet, not of the file's headers). Timestamps come from the
//! frames' own times, so the same frames always give the same bytes.

use std::fmt;
use std::io::{self, Read, Write};
use std::time::Duration;

use crate::frame::{CanFrame, Stamped, MAX_DLC};

/// `LINKTYPE_CAN_SOCKETCAN`: a SocketCAN `struct can_frame` with the ID in network byte order.
pub const LINKTYPE_CAN_SOCKETCAN: u32 = 227;
/// Magic number of a pcap file with microsecond timestamps.
pub const MAGIC_MICROS: u32 = 0xA1B2_C3D4;
/// Magic number of a pcap file with nanosecond timestamps.
pub const MAGIC_NANOS: u32 = 0xA1B2_3C4D;
/// Block type that starts a pcapng file (not read here).
const PCAPNG_MAGIC: u32 = 0x0A0D_0D0A;
/// Bytes of the global header.
pub const FILE_HEADER_LEN: usize = 24;
/// Bytes of a record header.
pub const RECORD_HEADER_LEN: usize = 16;
/// Bytes of a classic CAN packet as written: 8 of header and 8 of (padded) payload.
pub const PACKET_LEN: usize = 16;
/// The snapshot length the writer declares.
pub const SNAPLEN: u32 = 65_535;
/// Extended-frame flag of the CAN ID field.
pub const CAN_EFF_FLAG: u32 = 0x8000_0000;
/// Remote-frame flag of the CAN ID field.
pub const CAN_RTR_FLAG: u32 = 0x4000_0000;
/// Error-frame flag of the CAN ID field.
pub const CAN_ERR_FLAG: u32 = 0x2000_0000;

/// Why bytes are not a SocketCAN pcap file this link can read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PcapError {
    /// The file is shorter than its 24-byte header.
    NoHeader,
    /// The magic number is not a pcap file's.
    NotPcap(u32),
    /// A pcapng file (Wireshark's default format).
    Pcapng,
    /// Another link type than SocketCAN.
    LinkType(u32),
    /// Record `n` (0-based) ends before its header or data do.
    Truncated(usize),
    /// Record `n` is too short for a CAN header, or its payload length is above 8 (CAN FD).
    BadPacket(usize),
    /// Record `n` is a remote or error frame, which this link does not carry.
    Unsupported(usize),
    /// A frame's time does not fit a pcap timestamp (before 1970 or after 2106).
    TimeRange,
}

impl fmt::Display for PcapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PcapError::NoHeader => write!(f, "not a pcap file: shorter than its 24-byte header"),
            PcapError::NotPcap(m) => write!(f, "not a pcap file (magic number {m:08X})"),
            PcapError::Pcapng => write!(
                f,
                "a pcapng file: save it as pcap (`editcap -F pcap IN OUT` or Wireshark's \
                 \"Save as… pcap\") first"
            ),
            PcapError::LinkType(t) => {
                write!(f, "link type {t} is not SocketCAN ({LINKTYPE_CAN_SOCKETCAN})")
            }
            PcapError::Truncated(n) => write!(f, "record {n} is cut short (truncated file)"),
            PcapError::BadPacket(n) => {
                write!(f, "record {n} is not a classic CAN frame (too short, or CAN FD)")
            }
            PcapError::Unsupported(n) => {
                write!(f, "record {n} is a remote or error frame, which are not supported")
            }
            PcapError::TimeRange => write!(f, "a frame's time does not fit a pcap timestamp"),
        }
    }
}

impl std::error::Error for PcapError {}

impl From<PcapError> for io::Error {
    fn from(e: PcapError) -> Self {
        io::Error::new(io::ErrorKind::InvalidData, e)
    }
}

/// The 24-byte global header (little-endian, microseconds, link type 227).
pub fn file_header() -> [u8; FILE_HEADER_LEN] {
    let mut h = [0u8; FILE_HEADER_LEN];
    h[0..4].copy_from_slice(&MAGIC_MICROS.to_le_bytes());
    h[4..6].copy_from_slice(&2u16.to_le_bytes());
    h[6..8].copy_from_slice(&4u16.to_le_bytes());
    // thiszone (8..12) and sigfigs (12..16) stay 0.
    h[16..20].copy_from_slice(&SNAPLEN.to_le_bytes());
    h[20..24].copy_from_slice(&LINKTYPE_CAN_SOCKETCAN.to_le_bytes());
    h
}

/// A frame as a `LINKTYPE_CAN_SOCKETCAN` packet: ID and flags big-endian, length, three zero
/// bytes, the payload zero-padded to 8.
pub fn encode_packet(frame: &CanFrame) -> [u8; PACKET_LEN] {
    let mut p = [0u8; PACKET_LEN];
    let id = frame.id() | if frame.is_extended() { CAN_EFF_FLAG } else { 0 };
    p[0..4].copy_from_slice(&id.to_be_bytes());
    p[4] = frame.len() as u8;
    p[8..8 + frame.len()].copy_from_slice(frame.data());
    p
}

/// Reads a `LINKTYPE_CAN_SOCKETCAN` packet (record `n`, for errors). Accepts a payload
/// padded to 8 bytes or not.
pub fn decode_packet(p: &[u8], n: usize) -> Result<CanFrame, PcapError> {
    if p.len() < 8 {
        return Err(PcapError::BadPacket(n));
    }
    let raw = u32::from_be_bytes([p[0], p[1], p[2], p[3]]);
    let len = usize::from(p[4]);
    if len > MAX_DLC || p.len() < 8 + len {
        return Err(PcapError::BadPacket(n));
    }
    if raw & (CAN_RTR_FLAG | CAN_ERR_FLAG) != 0 {
        return Err(PcapError::Unsupported(n));
    }
    let extended = raw & CAN_EFF_FLAG != 0;
    let id = raw & !(CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG);
    CanFrame::new(id, extended, &p[8..8 + len]).map_err(|_| PcapError::BadPacket(n))
}

/// Writes frames to a pcap file; the global header goes out with [`PcapWriter::new`].
pub struct PcapWriter<W: Write> {
    out: W,
}

impl<W: Write> PcapWriter<W> {
    /// Starts a pcap file on `out`.
    pub fn new(mut out: W) -> io::Result<Self> {
        out.write_all(&file_header())?;
        Ok(Self { out })
    }

    /// Writes one frame, stamped with its own time (µs resolution).
    pub fn write(&mut self, s: &Stamped) -> io::Result<()> {
        let secs = u32::try_from(s.time.as_secs()).map_err(|_| PcapError::TimeRange)?;
        let mut rec = [0u8; RECORD_HEADER_LEN + PACKET_LEN];
        rec[0..4].copy_from_slice(&secs.to_le_bytes());
        rec[4..8].copy_from_slice(&s.time.subsec_micros().to_le_bytes());
        rec[8..12].copy_from_slice(&(PACKET_LEN as u32).to_le_bytes());
        rec[12..16].copy_from_slice(&(PACKET_LEN as u32).to_le_bytes());
        rec[RECORD_HEADER_LEN..].copy_from_slice(&encode_packet(&s.frame));
        self.out.write_all(&rec)
    }

    /// Flushes the underlying writer.
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.out
    }
}

/// Writes `frames` as a whole pcap file.
pub fn write_pcap<W: Write>(out: W, frames: &[Stamped]) -> io::Result<W> {
    let mut w = PcapWriter::new(out)?;
    for s in frames {
        w.write(s)?;
    }
    w.flush()?;
    Ok(w.into_inner())
}

/// True if `head` (a file's first bytes) starts like a pcap or pcapng file.
pub fn looks_like_pcap(head: &[u8]) -> bool {
    let Some(m) = head.get(..4) else { return false };
    let m = [m[0], m[1], m[2], m[3]];
    [MAGIC_MICROS, MAGIC_NANOS, PCAPNG_MAGIC]
        .iter()
        .any(|&magic| magic.to_le_bytes() == m || magic.to_be_bytes() == m)
}

/// Reads a whole SocketCAN pcap file. Errors name the record.
pub fn read_pcap<R: Read>(mut input: R) -> io::Result<Vec<Stamped>> {
    let mut bytes = Vec::new();
    input.read_to_end(&mut bytes)?;
    Ok(parse_pcap(&bytes)?)
}

/// Parses a whole SocketCAN pcap file held in memory.
pub fn parse_pcap(bytes: &[u8]) -> Result<Vec<Stamped>, PcapError> {
    let head = bytes.get(..FILE_HEADER_LEN).ok_or(PcapError::NoHeader)?;
    let magic = [head[0], head[1], head[2], head[3]];
    let (big, nanos) = if magic == MAGIC_MICROS.to_le_bytes() {
        (false, false)
    } else if magic == MAGIC_MICROS.to_be_bytes() {
        (true, false)
    } else if magic == MAGIC_NANOS.to_le_bytes() {
        (false, true)
    } else if magic == MAGIC_NANOS.to_be_bytes() {
        (true, true)
    } else if magic == PCAPNG_MAGIC.to_le_bytes() {
        return Err(PcapError::Pcapng);
    } else {
        return Err(PcapError::NotPcap(u32::from_be_bytes(magic)));
    };
    let u32_at = |b: &[u8], at: usize| {
        let w = [b[at], b[at + 1], b[at + 2], b[at + 3]];
        if big {
            u32::from_be_bytes(w)
        } else {
            u32::from_le_bytes(w)
        }
    };
    let link = u32_at(head, 20);
    if link != LINKTYPE_CAN_SOCKETCAN {
        return Err(PcapError::LinkType(link));
    }
    let mut out = Vec::new();
    let mut at = FILE_HEADER_LEN;
    let mut n = 0;
    while at < bytes.len() {
        let rec = bytes.get(at..at + RECORD_HEADER_LEN).ok_or(PcapError::Truncated(n))?;
        let (secs, frac, incl) = (u32_at(rec, 0), u32_at(rec, 4), u32_at(rec, 8) as usize);
        let body = at + RECORD_HEADER_LEN;
        let packet = bytes.get(body..body + incl).ok_or(PcapError::Truncated(n))?;
        let sub = if nanos { frac } else { frac.saturating_mul(1000) };
        // Keep microsecond resolution, as the other trace format does.
        let time = Duration::new(u64::from(secs), 0) + Duration::from_micros(u64::from(sub) / 1000);
        out.push(Stamped { time, frame: decode_packet(packet, n)? });
        at = body + incl;
        n += 1;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamped(secs: u64, us: u32, frame: CanFrame) -> Stamped {
        Stamped { time: Duration::new(secs, us * 1000), frame }
    }

    #[test]
    fn the_file_is_laid_out_as_the_link_type_spec_says() {
        let frames = [
            stamped(1_700_000_000, 123, CanFrame::extended(0x1F80_8003, &[0x11, 0xAA]).unwrap()),
            stamped(1_700_000_001, 999_999, CanFrame::standard(0x123, &[]).unwrap()),
        ];
        let file = write_pcap(Vec::new(), &frames).unwrap();
        assert_eq!(file.len(), 24 + 2 * (16 + 16));
        #[rustfmt::skip]
        let expected_head = [
            0xD4, 0xC3, 0xB2, 0xA1, // magic, little-endian, microseconds
            2, 0, 4, 0,             // version 2.4
            0, 0, 0, 0, 0, 0, 0, 0, // thiszone, sigfigs
            0xFF, 0xFF, 0, 0,       // snaplen 65535
            227, 0, 0, 0,           // LINKTYPE_CAN_SOCKETCAN
        ];
        assert_eq!(file[..24], expected_head);
        #[rustfmt::skip]
        let first = [
            0x00, 0xF1, 0x53, 0x65, // 1_700_000_000 s
            123, 0, 0, 0,           // µs
            16, 0, 0, 0, 16, 0, 0, 0,
            0x9F, 0x80, 0x80, 0x03, // ID big-endian with the extended flag
            2, 0, 0, 0,             // length, padding, reserved
            0x11, 0xAA, 0, 0, 0, 0, 0, 0,
        ];
        assert_eq!(file[24..56], first);
        // A standard frame has no flag; its 11-bit ID is still big-endian.
        assert_eq!(file[56 + 4..56 + 8], 999_999u32.to_le_bytes());
        assert_eq!(file[56 + 16..56 + 24], [0x00, 0x00, 0x01, 0x23, 0, 0, 0, 0]);
    }

    #[test]
    fn roundtrips_and_is_deterministic() {
        let frames: Vec<Stamped> = (0..50u32)
            .map(|i| {
                let data: Vec<u8> = (0..(i % 9) as u8).collect();
                let f = if i % 3 == 0 {
                    CanFrame::standard(i * 7 % 0x800, &data).unwrap()
                } else {
                    CanFrame::extended(i * 0x0123_4567 % 0x2000_0000, &data).unwrap()
                };
                stamped(1_700_000_000 + u64::from(i / 10), i * 20_011 % 1_000_000, f)
            })
            .collect();
        let a = write_pcap(Vec::new(), &frames).unwrap();
        assert_eq!(a, write_pcap(Vec::new(), &frames).unwrap());
        assert_eq!(read_pcap(&a[..]).unwrap(), frames);
    }

    #[test]
    fn reads_big_endian_nanosecond_and_unpadded_files() {
        let mut file = Vec::new();
        file.extend_from_slice(&MAGIC_NANOS.to_be_bytes());
        file.extend_from_slice(&[0, 2, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 16, 0, 0, 0, 227]);
        file.extend_from_slice(&5u32.to_be_bytes());
        file.extend_from_slice(&1_500_999u32.to_be_bytes()); // ns: 1.500999 ms
        file.extend_from_slice(&[0, 0, 0, 9, 0, 0, 0, 9]);
        file.extend_from_slice(&[0x80, 0, 0, 0x7F, 1, 0, 0, 0, 0xEE]); // unpadded, 1 byte
        let got = parse_pcap(&file).unwrap();
        assert_eq!(got, [stamped(5, 1_500, CanFrame::extended(0x7F, &[0xEE]).unwrap())]);
    }

    #[test]
    fn bad_files_get_specific_errors() {
        let good =
            write_pcap(Vec::new(), &[stamped(1, 0, CanFrame::standard(1, &[1]).unwrap())]).unwrap();
        assert_eq!(parse_pcap(&good[..10]), Err(PcapError::NoHeader));
        assert_eq!(parse_pcap(&[b'('; 40]), Err(PcapError::NotPcap(0x2828_2828)));
        let mut ng = good.clone();
        ng[..4].copy_from_slice(&PCAPNG_MAGIC.to_le_bytes());
        assert_eq!(parse_pcap(&ng), Err(PcapError::Pcapng));
        let mut eth = good.clone();
        eth[20] = 1;
        assert_eq!(parse_pcap(&eth), Err(PcapError::LinkType(1)));
        assert_eq!(parse_pcap(&good[..good.len() - 1]), Err(PcapError::Truncated(0)));
        assert_eq!(parse_pcap(&good[..30]), Err(PcapError::Truncated(0)));
        let mut fd = good.clone();
        fd[24 + 16 + 4] = 12;
        assert_eq!(parse_pcap(&fd), Err(PcapError::BadPacket(0)));
        let mut rtr = good.clone();
        rtr[24 + 16] |= 0x40;
        assert_eq!(parse_pcap(&rtr), Err(PcapError::Unsupported(0)));
        let late = stamped(1 << 32, 0, CanFrame::standard(1, &[]).unwrap());
        assert!(PcapWriter::new(Vec::new()).unwrap().write(&late).is_err());
        assert!(looks_like_pcap(&good) && looks_like_pcap(&ng) && !looks_like_pcap(b"(1.0)"));
        assert!(PcapError::Pcapng.to_string().contains("editcap -F pcap"));
    }
}
