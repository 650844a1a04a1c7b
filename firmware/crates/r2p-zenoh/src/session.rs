//! A Zenoh 1.x client session, sans-IO: the transport's handshake (INIT, OPEN), keep-alives,
//! the lease, CLOSE, and the network messages a gateway needs (declare a key expression, a
//! subscriber, a liveliness token, an interest in the subscribers of a key expression; push a
//! put with an attachment; receive puts and the router's subscriber declarations).
//!
//! On a stream link (TCP) every batch is prefixed with its length, 2 bytes little-endian: the
//! caller reads the 2 bytes, then that many ([`Session::receive`] takes one batch); what the
//! session writes already carries the prefix.
//!
//! The wire format is Zenoh's protocol version 0x09 as zenoh-protocol 1.10 documents it
//! (`transport/init.rs`, `open.rs`, `frame.rs`, `network/push.rs`, `declare.rs`,
//! `zenoh/put.rs`, `network/interest.rs`): only what a client sends is encoded, and what a
//! router sends is read far enough to use or skip it. Interests from the router are read past;
//! anything else in a frame (a request, a response, OAM) ends that frame's reading: it is
//! counted in [`Stats::skipped`], never a panic.
//!
//! Subscribers, through an interest: in Zenoh 1.x a router tells a client of other nodes'
//! subscribers only when the client asked (an INTEREST: current and future subscribers,
//! restricted to a key expression); it answers with a DECLARE SUBSCRIBER (with the interest's
//! id) for each that matches now, a DECLARE FINAL (with the id), then DECLARE / UNDECLARE
//! SUBSCRIBER (without it) as they come and go — one per key expression, whoever holds it.
//! zenoh-pico's write filter (`Z_FEATURE_INTEREST`) works this way; so does
//! [`crate::matching`], which turns these [`Event`]s into "who listens to what I publish".

use heapless::{String, Vec};

use crate::codec::{ext, Malformed, Overflow, Reader, Writer};

/// Zenoh's protocol version.
pub const VERSION: u8 = 0x09;
/// Longest key expression the session keeps (router mappings, its own declarations).
pub const MAX_KEY: usize = 256;
/// Key expressions the router may declare to this client and be remembered.
pub const MAX_REMOTE_KEYS: usize = 4;
/// Longest cookie from the router's INIT ack.
pub const MAX_COOKIE: usize = 256;

mod id {
    pub const INIT: u8 = 0x01;
    pub const OPEN: u8 = 0x02;
    pub const CLOSE: u8 = 0x03;
    pub const KEEP_ALIVE: u8 = 0x04;
    pub const FRAME: u8 = 0x05;
    pub const DECLARE: u8 = 0x1e;
    pub const PUSH: u8 = 0x1d;
    pub const INTEREST: u8 = 0x19;
    pub const PUT: u8 = 0x01;
    pub const D_KEYEXPR: u8 = 0x00;
    pub const U_KEYEXPR: u8 = 0x01;
    pub const D_SUBSCRIBER: u8 = 0x02;
    pub const U_SUBSCRIBER: u8 = 0x03;
    pub const D_TOKEN: u8 = 0x06;
    pub const D_FINAL: u8 = 0x1A;
}
const FLAG_A: u8 = 0x20; // INIT/OPEN: ack
const FLAG_S: u8 = 0x40; // INIT: size parameters; CLOSE (0x20): whole session
const FLAG_T: u8 = 0x40; // OPEN: lease in seconds
const FLAG_Z: u8 = 0x80; // extensions follow
const FLAG_N: u8 = 0x20; // key expression has a suffix
const FLAG_M: u8 = 0x40; // key expression in the sender's mapping
const FLAG_R: u8 = 0x20; // FRAME: reliable channel
const FLAG_I: u8 = 0x20; // DECLARE: interest id
/// INTEREST: current and future declarations (the mode, bits 5-6).
const MODE_CURRENT_FUTURE: u8 = 0b11 << 5;
/// INTEREST options: subscribers, restricted to a key expression, in the sender's mapping.
const OPT_S: u8 = 0x02;
const OPT_R: u8 = 0x10;
const OPT_N: u8 = 0x20;
const OPT_M: u8 = 0x40;
const PUT_T: u8 = 0x20; // PUT: timestamp
const PUT_E: u8 = 0x40; // PUT: encoding
const ATTACHMENT_ID: u8 = 0x03;
const WHATAMI_CLIENT: u8 = 0b10;
/// 32-bit sequence numbers and request ids (zenoh's default resolution).
const RESOLUTION: u8 = 0b1010;

/// The session's settings.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// This client's Zenoh ID (16 bytes, little-endian as Zenoh prints it; the last byte not 0,
    /// so all 16 are sent).
    pub zid: [u8; 16],
    /// The lease this client announces: the router closes the session after this long without
    /// hearing from it; keep-alives go out at a quarter of it.
    pub lease_ms: u32,
    /// The largest batch this client accepts (its receive buffer).
    pub rx_batch: u16,
}

/// Where the handshake is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    /// Not started, or closed.
    Closed,
    /// INIT sent, waiting for the ack.
    InitSent,
    /// OPEN sent, waiting for the ack.
    OpenSent,
    /// Open: declarations and data flow.
    Open,
}

/// Why the session ended (the caller closes the link and starts again).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SessionError {
    /// The router sent nothing for its whole lease.
    LeaseExpired,
    /// The router closed the session (its reason code).
    ClosedByRouter(u8),
    /// The handshake got a reply that does not fit (wrong version, not an ack, malformed).
    Handshake,
    /// The output buffer is too small for what the session must send.
    Overflow,
}

impl From<Overflow> for SessionError {
    fn from(_: Overflow) -> Self {
        SessionError::Overflow
    }
}

/// Counters (they only grow).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Batches received.
    pub batches: u32,
    /// Puts received and handed on.
    pub samples: u32,
    /// Batches or messages that were not well-formed: dropped.
    pub malformed: u32,
    /// Messages read past but not used (requests, interests, deletes, other declarations).
    pub skipped: u32,
    /// Frames sent.
    pub frames_sent: u32,
}

/// A key expression as received: a declared prefix and a suffix (either may be empty).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Key<'a> {
    /// The declared part.
    pub prefix: &'a str,
    /// The part in the message.
    pub suffix: &'a str,
}

impl Key<'_> {
    /// Whether the whole key is `key`.
    pub fn is(&self, key: &str) -> bool {
        key.len() == self.prefix.len() + self.suffix.len()
            && key.starts_with(self.prefix)
            && key.ends_with(self.suffix)
    }
}

/// The key expression of a subscriber the router declared, as the router named it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Declared<'a> {
    /// In full: a prefix the router declared (or none), then the suffix.
    Full(Key<'a>),
    /// This client's own key expression `expr_id` (as [`Net::declare_keyexpr`] declared it),
    /// then `suffix`: what a router sends for a subscriber on exactly a key this client
    /// declared.
    Own {
        /// The key expression's id in this client's mapping.
        expr_id: u16,
        /// What follows it.
        suffix: &'a str,
    },
    /// A prefix the router declared that this session no longer remembers (it keeps
    /// [`MAX_REMOTE_KEYS`]): the key is not known.
    Unknown,
}

/// What a received batch brought.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event<'a> {
    /// The handshake completed: declare and publish now.
    Opened,
    /// A put on a key this client subscribed to.
    Sample {
        /// Its key expression.
        key: Key<'a>,
        /// Its payload.
        payload: &'a [u8],
        /// Its attachment, if any.
        attachment: Option<&'a [u8]>,
    },
    /// A subscriber behind the router that matches one of this client's interests
    /// ([`Net::declare_interest`]). `id` is the router's: one per key expression, whoever
    /// subscribes on it; it may come again (for another interest it matches).
    Subscriber {
        /// The router's id for it.
        id: u32,
        /// Its key expression.
        key: Declared<'a>,
    },
    /// The router's subscriber `id` is gone (the last one on its key expression left).
    SubscriberGone {
        /// The router's id.
        id: u32,
    },
    /// Every subscriber that matched interest `id` when it arrived has been declared: from
    /// now on, only changes come.
    InterestFinal {
        /// The interest's id.
        id: u32,
    },
}

/// The client session.
pub struct Session {
    cfg: Config,
    state: State,
    cookie: Vec<u8, MAX_COOKIE>,
    router_lease_us: u64,
    tx_sn: u32,
    last_rx_us: u64,
    last_tx_us: u64,
    tx_batch: u16,
    remote_keys: Vec<(u16, String<MAX_KEY>), MAX_REMOTE_KEYS>,
    stats: Stats,
}

impl Session {
    /// A closed session.
    pub fn new(cfg: Config) -> Self {
        Self {
            cfg,
            state: State::Closed,
            cookie: Vec::new(),
            router_lease_us: u64::from(cfg.lease_ms) * 1000,
            tx_sn: 0,
            last_rx_us: 0,
            last_tx_us: 0,
            tx_batch: cfg.rx_batch,
            remote_keys: Vec::new(),
            stats: Stats::default(),
        }
    }

    /// Where the handshake is.
    pub fn state(&self) -> State {
        self.state
    }

    /// The counters.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// The largest batch the router accepts (what [`Session::send`] must stay within).
    pub fn tx_batch(&self) -> u16 {
        self.tx_batch
    }

    /// Starts a session on a fresh link: writes the INIT (with its length prefix) into `out`.
    pub fn start(&mut self, now_us: u64, out: &mut [u8]) -> Result<usize, SessionError> {
        self.state = State::InitSent;
        self.cookie.clear();
        self.remote_keys.clear();
        self.last_rx_us = now_us;
        self.last_tx_us = now_us;
        self.tx_batch = self.cfg.rx_batch;
        batch(out, |w| {
            w.u8(id::INIT | FLAG_S);
            w.u8(VERSION);
            w.u8(((16 - 1) << 4) | WHATAMI_CLIENT);
            w.bytes(&self.cfg.zid);
            w.u8(RESOLUTION);
            w.bytes(&self.cfg.rx_batch.to_le_bytes());
        })
        .map_err(Into::into)
    }

    /// Handles one batch from the router (without its length prefix). Returns the bytes to
    /// send back in `out` (the OPEN after the INIT ack; else 0) and hands events to `on`.
    /// A malformed batch is counted and dropped; only a broken handshake, a CLOSE or an
    /// output overflow end the session.
    pub fn receive(
        &mut self,
        now_us: u64,
        input: &[u8],
        out: &mut [u8],
        mut on: impl FnMut(Event<'_>),
    ) -> Result<usize, SessionError> {
        self.last_rx_us = now_us;
        self.stats.batches = self.stats.batches.wrapping_add(1);
        match self.state {
            State::Closed => Ok(0),
            State::InitSent => {
                let n = self.on_init_ack(input, out).map_err(|_| SessionError::Handshake)?;
                self.state = State::OpenSent;
                self.last_tx_us = now_us;
                Ok(n)
            }
            State::OpenSent => {
                self.on_open_ack(input).map_err(|_| SessionError::Handshake)?;
                self.state = State::Open;
                on(Event::Opened);
                Ok(0)
            }
            State::Open => {
                let mut r = Reader::new(input);
                while r.remaining() > 0 {
                    match self.transport_message(&mut r, &mut on) {
                        Ok(()) => {}
                        Err(Step::Closed(reason)) => {
                            self.state = State::Closed;
                            return Err(SessionError::ClosedByRouter(reason));
                        }
                        Err(Step::Malformed) => {
                            self.stats.malformed = self.stats.malformed.wrapping_add(1);
                            break;
                        }
                        Err(Step::Stop) => {
                            self.stats.skipped = self.stats.skipped.wrapping_add(1);
                            break;
                        }
                    }
                }
                Ok(0)
            }
        }
    }

    /// Time passing: a keep-alive when nothing was sent for a quarter of this client's lease
    /// (returns its bytes), or [`SessionError::LeaseExpired`] when the router was silent
    /// for its lease (or the handshake for this client's).
    pub fn poll(&mut self, now_us: u64, out: &mut [u8]) -> Result<usize, SessionError> {
        let lease = match self.state {
            State::Closed => return Ok(0),
            State::Open => self.router_lease_us,
            _ => u64::from(self.cfg.lease_ms) * 1000,
        };
        if now_us.saturating_sub(self.last_rx_us) > lease {
            self.state = State::Closed;
            return Err(SessionError::LeaseExpired);
        }
        let keep_alive_us = u64::from(self.cfg.lease_ms) * 1000 / 4;
        if self.state == State::Open && now_us.saturating_sub(self.last_tx_us) >= keep_alive_us {
            self.last_tx_us = now_us;
            return batch(out, |w| w.u8(id::KEEP_ALIVE)).map_err(Into::into);
        }
        Ok(0)
    }

    /// Writes a CLOSE of the whole session (the caller then drops the link).
    pub fn close(&mut self, out: &mut [u8]) -> Result<usize, SessionError> {
        self.state = State::Closed;
        batch(out, |w| {
            w.u8(id::CLOSE | 0x20);
            w.u8(0); // generic
        })
        .map_err(Into::into)
    }

    /// Writes one frame of network messages (declarations, puts) on the reliable channel.
    /// `f` writes them through a [`Net`]; a frame larger than the router's batch size is
    /// refused as an overflow (nothing to send).
    pub fn send(
        &mut self,
        now_us: u64,
        out: &mut [u8],
        f: impl FnOnce(&mut Net<'_, '_>),
    ) -> Result<usize, SessionError> {
        if self.state != State::Open {
            return Ok(0);
        }
        let limit = usize::from(self.tx_batch) + 2;
        let out = match out.len() > limit {
            true => &mut out[..limit],
            false => out,
        };
        let sn = self.tx_sn;
        let n = batch(out, |w| {
            w.u8(id::FRAME | FLAG_R);
            w.zint(u64::from(sn));
            f(&mut Net { w });
        })?;
        self.tx_sn = sn.wrapping_add(1);
        self.last_tx_us = now_us;
        self.stats.frames_sent = self.stats.frames_sent.wrapping_add(1);
        Ok(n)
    }

    fn on_init_ack(&mut self, input: &[u8], out: &mut [u8]) -> Result<usize, Malformed> {
        let mut r = Reader::new(input);
        let h = r.u8()?;
        if h & 0x1F != id::INIT || h & FLAG_A == 0 || r.u8()? != VERSION {
            return Err(Malformed);
        }
        let flags = r.u8()?;
        r.bytes(1 + usize::from(flags >> 4))?; // the router's ZID
        if h & FLAG_S != 0 {
            let resolution = r.u8()?;
            if resolution & 0b11 != RESOLUTION & 0b11 {
                return Err(Malformed); // this client counts frames in 32 bits only
            }
            let b = r.bytes(2)?;
            self.tx_batch = u16::from_le_bytes([b[0], b[1]]).min(self.cfg.rx_batch);
        }
        let cookie = r.zbytes()?;
        self.cookie = Vec::from_slice(cookie).map_err(|_| Malformed)?;
        if h & FLAG_Z != 0 {
            r.skip_extensions()?;
        }
        // The initial sequence number: any is valid; derive one from the ZID.
        self.tx_sn = u32::from_le_bytes([self.cfg.zid[0], self.cfg.zid[1], self.cfg.zid[2], 0]);
        let lease_s = self.cfg.lease_ms / 1000;
        let whole_seconds = self.cfg.lease_ms.is_multiple_of(1000);
        let (sn, cookie) = (self.tx_sn, &self.cookie);
        batch(out, |w| {
            w.u8(id::OPEN | if whole_seconds { FLAG_T } else { 0 });
            w.zint(u64::from(if whole_seconds { lease_s } else { self.cfg.lease_ms }));
            w.zint(u64::from(sn));
            w.zbytes(cookie);
        })
        .map_err(|_| Malformed)
    }

    fn on_open_ack(&mut self, input: &[u8]) -> Result<(), Malformed> {
        let mut r = Reader::new(input);
        let h = r.u8()?;
        if h & 0x1F != id::OPEN || h & FLAG_A == 0 {
            return Err(Malformed);
        }
        let lease = r.zint()?;
        self.router_lease_us = if h & FLAG_T != 0 {
            lease.saturating_mul(1_000_000)
        } else {
            lease.saturating_mul(1000)
        };
        r.zint()?; // the router's initial sequence number
        if h & FLAG_Z != 0 {
            r.skip_extensions()?;
        }
        Ok(())
    }

    fn transport_message(
        &mut self,
        r: &mut Reader<'_>,
        on: &mut impl FnMut(Event<'_>),
    ) -> Result<(), Step> {
        let h = r.u8()?;
        match h & 0x1F {
            id::KEEP_ALIVE => {
                if h & FLAG_Z != 0 {
                    r.skip_extensions()?;
                }
                Ok(())
            }
            id::CLOSE => Err(Step::Closed(r.u8().unwrap_or(0))),
            id::FRAME => {
                r.zint()?; // sequence number: TCP keeps the order
                if h & FLAG_Z != 0 {
                    r.skip_extensions()?;
                }
                while let Some(next) = r.peek() {
                    if !matches!(next & 0x1F, 0x19..=0x1F) {
                        break; // the next transport message
                    }
                    self.network_message(r, on)?;
                }
                Ok(())
            }
            _ => Err(Step::Stop),
        }
    }

    fn network_message(
        &mut self,
        r: &mut Reader<'_>,
        on: &mut impl FnMut(Event<'_>),
    ) -> Result<(), Step> {
        let h = r.u8()?;
        match h & 0x1F {
            id::PUSH => {
                let (scope, suffix) = wire_expr(r, h)?;
                if h & FLAG_Z != 0 {
                    r.skip_extensions()?;
                }
                let body = r.u8()?;
                if body & 0x1F != id::PUT {
                    return Err(Step::Stop); // a delete: nothing the gateway uses
                }
                if body & PUT_T != 0 {
                    r.zint()?; // NTP64 time
                    r.zbytes()?; // the timestamp's ID
                }
                if body & PUT_E != 0 {
                    let enc = r.zint()?;
                    if enc & 1 != 0 {
                        r.zbytes()?; // schema
                    }
                }
                let mut attachment = None;
                if body & FLAG_Z != 0 {
                    r.extensions(|id, b| {
                        if id == ATTACHMENT_ID {
                            attachment = Some(b);
                        }
                    })?;
                }
                let payload = r.zbytes()?;
                let prefix = match scope {
                    0 => "",
                    // The router's mapping; this client's own key ids name what it publishes,
                    // never what it subscribes to, so a put by them is not for it.
                    id if h & FLAG_M != 0 => lookup(&self.remote_keys, id).ok_or(Step::Stop)?,
                    _ => return Err(Step::Stop),
                };
                self.stats.samples = self.stats.samples.wrapping_add(1);
                on(Event::Sample { key: Key { prefix, suffix }, payload, attachment });
                Ok(())
            }
            id::DECLARE => {
                let interest = match h & FLAG_I {
                    0 => None,
                    _ => Some(r.zint_max(u64::from(u32::MAX))? as u32),
                };
                if h & FLAG_Z != 0 {
                    r.skip_extensions()?;
                }
                let d = r.u8()?;
                match d & 0x1F {
                    id::D_KEYEXPR => {
                        let expr_id = r.zint_max(u64::from(u16::MAX))? as u16;
                        let (scope, suffix) = wire_expr(r, d & FLAG_N)?;
                        if d & FLAG_Z != 0 {
                            r.skip_extensions()?;
                        }
                        let mut key: String<MAX_KEY> = String::new();
                        if scope != 0 {
                            let base = lookup(&self.remote_keys, scope).ok_or(Step::Stop)?;
                            key.push_str(base).map_err(|_| Step::Stop)?;
                        }
                        key.push_str(suffix).map_err(|_| Step::Stop)?;
                        self.remote_keys.retain(|(id, _)| *id != expr_id);
                        if self.remote_keys.is_full() {
                            self.remote_keys.remove(0);
                        }
                        let _ = self.remote_keys.push((expr_id, key));
                        Ok(())
                    }
                    id::U_KEYEXPR => {
                        let expr_id = r.zint()?;
                        self.remote_keys.retain(|(id, _)| u64::from(*id) != expr_id);
                        if d & FLAG_Z != 0 {
                            r.skip_extensions()?;
                        }
                        Ok(())
                    }
                    id::D_SUBSCRIBER => {
                        let id = r.zint_max(u64::from(u32::MAX))? as u32;
                        let (scope, suffix) = wire_expr(r, d & FLAG_N)?;
                        if d & FLAG_Z != 0 {
                            r.skip_extensions()?;
                        }
                        let key = match scope {
                            0 => Declared::Full(Key { prefix: "", suffix }),
                            // The router's mapping.
                            s if d & FLAG_M != 0 => match lookup(&self.remote_keys, s) {
                                Some(prefix) => Declared::Full(Key { prefix, suffix }),
                                None => Declared::Unknown,
                            },
                            expr_id => Declared::Own { expr_id, suffix },
                        };
                        on(Event::Subscriber { id, key });
                        Ok(())
                    }
                    id::U_SUBSCRIBER => {
                        let id = r.zint_max(u64::from(u32::MAX))? as u32;
                        if d & FLAG_Z != 0 {
                            r.skip_extensions()?; // its key expression, if the router sent it
                        }
                        on(Event::SubscriberGone { id });
                        Ok(())
                    }
                    0x04 | 0x06 => {
                        // another node's queryable or token: read past it
                        r.zint()?;
                        wire_expr(r, d & FLAG_N)?;
                        if d & FLAG_Z != 0 {
                            r.skip_extensions()?;
                        }
                        self.stats.skipped = self.stats.skipped.wrapping_add(1);
                        Ok(())
                    }
                    0x05 | 0x07 => {
                        r.zint()?;
                        if d & FLAG_Z != 0 {
                            r.skip_extensions()?;
                        }
                        self.stats.skipped = self.stats.skipped.wrapping_add(1);
                        Ok(())
                    }
                    id::D_FINAL => {
                        if d & FLAG_Z != 0 {
                            r.skip_extensions()?;
                        }
                        match interest {
                            Some(id) => on(Event::InterestFinal { id }),
                            None => self.stats.skipped = self.stats.skipped.wrapping_add(1),
                        }
                        Ok(())
                    }
                    _ => Err(Step::Malformed),
                }
            }
            id::INTEREST => {
                // The router's interest in this client's declarations: it has them all already
                // (they are sent once a session, unasked). Read past it.
                r.zint()?; // its id
                if h & MODE_CURRENT_FUTURE != 0 {
                    let options = r.u8()?;
                    if options & OPT_R != 0 {
                        wire_expr(r, if options & OPT_N != 0 { FLAG_N } else { 0 })?;
                    }
                }
                if h & FLAG_Z != 0 {
                    r.skip_extensions()?;
                }
                self.stats.skipped = self.stats.skipped.wrapping_add(1);
                Ok(())
            }
            // A request, response or OAM: not for a client that only publishes, subscribes and
            // holds tokens. Their lengths are not self-describing here: stop.
            _ => Err(Step::Stop),
        }
    }
}

/// How reading a batch stopped early.
enum Step {
    Malformed,
    Stop,
    Closed(u8),
}

impl From<Malformed> for Step {
    fn from(_: Malformed) -> Self {
        Step::Malformed
    }
}

fn lookup<const N: usize>(keys: &[(u16, String<N>)], id: u16) -> Option<&str> {
    keys.iter().find(|(k, _)| *k == id).map(|(_, s)| s.as_str())
}

/// `key_scope: z16`, then `key_suffix: <u8;z16>` if N (in `header`).
fn wire_expr<'a>(r: &mut Reader<'a>, header: u8) -> Result<(u16, &'a str), Malformed> {
    let scope = r.zint_max(u64::from(u16::MAX))? as u16;
    let suffix = if header & FLAG_N != 0 {
        core::str::from_utf8(r.zbytes()?).map_err(|_| Malformed)?
    } else {
        ""
    };
    Ok((scope, suffix))
}

/// Writes one batch with its 2-byte length prefix.
fn batch(out: &mut [u8], f: impl FnOnce(&mut Writer<'_>)) -> Result<usize, Overflow> {
    let mut w = Writer::new(out);
    w.bytes(&[0, 0]);
    f(&mut w);
    let len = w.len().saturating_sub(2);
    if len > usize::from(u16::MAX) {
        return Err(Overflow);
    }
    w.patch_u16_le(0, len as u16);
    w.finish()
}

/// The network messages of one frame.
pub struct Net<'w, 'b> {
    w: &'w mut Writer<'b>,
}

impl Net<'_, '_> {
    /// Declares `key` as the key expression `expr_id` (not 0) in this client's mapping:
    /// puts then name it by the id, not the whole string.
    pub fn declare_keyexpr(&mut self, expr_id: u16, key: &str) {
        self.w.u8(id::DECLARE);
        self.w.u8(id::D_KEYEXPR | FLAG_N);
        self.w.zint(u64::from(expr_id));
        self.w.zint(0);
        self.w.zbytes(key.as_bytes());
    }

    /// Declares a subscriber `sub_id` on `key`.
    pub fn declare_subscriber(&mut self, sub_id: u32, key: &str) {
        self.w.u8(id::DECLARE);
        self.w.u8(id::D_SUBSCRIBER | FLAG_N);
        self.w.zint(u64::from(sub_id));
        self.w.zint(0);
        self.w.zbytes(key.as_bytes());
    }

    /// Declares a liveliness token `token_id` on `key` (it lives as long as the session).
    pub fn declare_token(&mut self, token_id: u32, key: &str) {
        self.w.u8(id::DECLARE);
        self.w.u8(id::D_TOKEN | FLAG_N);
        self.w.zint(u64::from(token_id));
        self.w.zint(0);
        self.w.zbytes(key.as_bytes());
    }

    /// Asks the router for the subscribers on this client's key expression `expr_id` (declared
    /// before, [`Net::declare_keyexpr`]), now and as they come and go, as interest `interest_id`
    /// (any id, unique in the session): the router answers with [`Event::Subscriber`]s, an
    /// [`Event::InterestFinal`], then [`Event::Subscriber`] / [`Event::SubscriberGone`].
    pub fn declare_interest(&mut self, interest_id: u32, expr_id: u16) {
        self.w.u8(id::INTEREST | MODE_CURRENT_FUTURE);
        self.w.zint(u64::from(interest_id));
        self.w.u8(OPT_S | OPT_R | OPT_M);
        self.w.zint(u64::from(expr_id));
    }

    /// A put on the key expression `expr_id` this client declared, with an attachment.
    pub fn put(&mut self, expr_id: u16, payload: &[u8], attachment: Option<&[u8]>) {
        self.w.u8(id::PUSH | FLAG_M);
        self.w.zint(u64::from(expr_id));
        self.w.u8(id::PUT | if attachment.is_some() { FLAG_Z } else { 0 });
        if let Some(a) = attachment {
            self.w.u8(ext::ZBUF | ATTACHMENT_ID);
            self.w.zbytes(a);
        }
        self.w.zbytes(payload);
    }

    /// Bytes of the frame so far (with its length prefix and header).
    pub fn len(&self) -> usize {
        self.w.len()
    }

    /// Nothing written yet (never: the frame header is there).
    pub fn is_empty(&self) -> bool {
        self.w.is_empty()
    }
}
