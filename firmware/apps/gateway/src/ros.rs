//! R2P topics as ROS 2 topics over Zenoh (rmw_zenoh's conventions, `r2p-zenoh`), sans-IO: the
//! gateway's ROS 2 node, its publishers and its `/cmd_vel` subscription on one Zenoh session.
//!
//! | ROS 2 topic | type | direction | rate | QoS |
//! |---|---|---|---|---|
//! | `/cmd_vel` | geometry_msgs/msg/Twist | ROS → base (`cmd_vel`) | as sent; watchdog 500 ms | reliable |
//! | `/odom` | nav_msgs/msg/Odometry | base → ROS | 20 Hz | best effort |
//! | `/battery_state` | sensor_msgs/msg/BatteryState | PSU → ROS | 1 Hz | best effort |
//! | `/range_0` … `/range_3` | sensor_msgs/msg/Range | proximity → ROS | 10 Hz | best effort |
//! | `/imu/data` | sensor_msgs/msg/Imu | IMU → ROS | 50 Hz | best effort |
//! | `/imu/mag` | sensor_msgs/msg/MagneticField | IMU → ROS | 10 Hz | best effort |
//! | `/imu/pressure` | sensor_msgs/msg/FluidPressure | IMU → ROS | 10 Hz | best effort |
//! | `/gnss/fix` | sensor_msgs/msg/NavSatFix | IMU's GNSS receiver → ROS | 5 Hz | best effort |
//! | `/gateway/status` | r2p_msgs/msg/GatewayStatus | gateway → ROS | 1 Hz | reliable |
//! | `/psu/state`, `/psu/event`, `/motor1/fault` … `/motor3/fault` | r2p_msgs/msg/PsuState, PsuEvent, MotorFault | modules → ROS | each message once, as it comes | reliable |
//!
//! The board-support layer owns the link (a TCP connection to the router) and the clock; it
//! hands this bridge each batch it reads and the latest value of each R2P topic, and sends what
//! the bridge writes. A dropped link is [`RosBridge::connect`]ed again.
//!
//! Who listens: with each publisher's key expression the bridge declares an interest in its
//! subscribers (r2p-zenoh's `matching`), and the imports that feed it follow
//! ([`crate::demand`], [`RosBridge::follow`], [`RosBridge::wanted`]).

use r2p_msgs::{
    Barometer, Battery, GnssFix, Imu, MagneticField, Odometry, Proximity, R2pMessage, Twist2D,
};
use r2p_zenoh::mapping::{self, RangerSpec, Stamp};
use r2p_zenoh::matching::{interest_id, Matching, MatchingStats};
use r2p_zenoh::ros::{self, Entity, KeyString, NodeInfo, RosType, DEFAULT_QOS, SENSOR_QOS};
use r2p_zenoh::session::{Config, Event, Session, SessionError, State, Stats};
use r2p_zenoh::types::{self, R2pRosType};

use crate::demand::{Demand, DemandStats, Feed};
use crate::endpoints::MIRRORED;

/// The ROS node's name.
pub const NODE_NAME: &str = "r2p_gateway";
/// A `/cmd_vel` older than this stops the base (a zero command, once).
pub const CMD_WATCHDOG_US: u64 = 500_000;
/// The proximity module's rangers (Sharp GP2Y0A02-like infrared: 0.2–1.5 m).
pub const RANGER: RangerSpec =
    RangerSpec { radiation_type: 1, field_of_view: 0.05, min_range: 0.04, max_range: 3.0 };

/// The bridge's settings (gateway parameters).
#[derive(Clone, Copy, Debug)]
pub struct RosConfig<'a> {
    /// ROS domain ID (default 0).
    pub domain: u32,
    /// Namespace, without slashes at either end ("" for none, the default).
    pub namespace: &'a str,
    /// The session's Zenoh ID: from the MCU's unique ID.
    pub zid: [u8; 16],
}

/// The Zenoh ID of a gateway: its 12-byte unique ID, then `R2P` and a non-zero last byte (so
/// Zenoh sends all 16 bytes).
pub fn zid_of(uid: [u8; 12]) -> [u8; 16] {
    let mut z = [0u8; 16];
    z[..12].copy_from_slice(&uid);
    z[12..15].copy_from_slice(b"R2P");
    z[15] = 0x01;
    z
}

/// One published topic: its key id (declared once per session), GID, sequence number.
struct Pub {
    key: KeyString,
    gid: [u8; 16],
    seq: i64,
    /// 0: each new message once (`count` tells them apart).
    period_us: u64,
    count: u32,
    next_us: u64,
}

/// The publishers, by index.
pub mod topic {
    /// `/odom`.
    pub const ODOM: usize = 0;
    /// `/battery_state`.
    pub const BATTERY: usize = 1;
    /// `/range_0`; channel N is `RANGE0 + N`.
    pub const RANGE0: usize = 2;
    /// `/imu/data`.
    pub const IMU: usize = 6;
    /// `/gateway/status`.
    pub const STATUS: usize = 7;
    /// `/imu/mag`.
    pub const MAG: usize = 8;
    /// `/imu/pressure`.
    pub const PRESSURE: usize = 9;
    /// `/gnss/fix`.
    pub const GNSS: usize = 10;
    /// The first of the mirrored R2P topics (`crate::endpoints::MIRRORED`, in its order).
    pub const MIRRORED0: usize = 11;
    /// How many.
    pub const COUNT: usize = 16;
}

const TOPICS: [(&str, u32); topic::COUNT] = [
    ("/odom", 20),
    ("/battery_state", 1),
    ("/range_0", 10),
    ("/range_1", 10),
    ("/range_2", 10),
    ("/range_3", 10),
    ("/imu/data", 50),
    ("/gateway/status", 1),
    ("/imu/mag", 10),
    ("/imu/pressure", 10),
    ("/gnss/fix", 5),
    // The mirrored topics: each message once, as it arrives (rate 0).
    ("/psu/state", 0),
    ("/psu/event", 0),
    ("/motor1/fault", 0),
    ("/motor2/fault", 0),
    ("/motor3/fault", 0),
];

fn ros_type(i: usize) -> RosType {
    match i {
        topic::ODOM => types::ODOMETRY,
        topic::BATTERY => types::BATTERY_STATE,
        topic::IMU => types::IMU,
        topic::MAG => types::MAGNETIC_FIELD,
        topic::PRESSURE => types::FLUID_PRESSURE,
        topic::GNSS => types::NAV_SAT_FIX,
        topic::STATUS => r2p_type("GatewayStatus").map_or(types::ODOMETRY, |t| t.ros),
        i if i >= topic::MIRRORED0 => {
            r2p_type(MIRRORED[i - topic::MIRRORED0].1).map_or(types::ODOMETRY, |t| t.ros)
        }
        _ => types::RANGE,
    }
}

/// The generated layout of an R2P type.
pub fn r2p_type(name: &str) -> Option<&'static R2pRosType> {
    types::R2P_TYPES.iter().find(|t| t.name == name)
}

/// Counters of the bridge (the session's, and its own).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RosStats {
    /// The session's.
    pub session: Stats,
    /// Sessions opened.
    pub opened: u32,
    /// Samples published.
    pub published: u32,
    /// Samples held back by the write filter: the router had told that nobody subscribes to
    /// their key ([`Matching::sends`]).
    pub filtered: u32,
    /// `/cmd_vel` samples taken.
    pub cmd_vel: u32,
    /// `/cmd_vel` samples that were not a Twist: dropped.
    pub bad_cmd_vel: u32,
    /// Watchdog stops.
    pub watchdog_stops: u32,
    /// The router's subscribers of the published keys, as followed.
    pub matching: MatchingStats,
    /// The imports given up and wanted again.
    pub demand: DemandStats,
}

/// The latest R2P values the bridge publishes (the board-support layer keeps them current).
#[derive(Clone, Copy, Debug, Default)]
pub struct Latest {
    /// The base's odometry.
    pub odom: Option<Odometry>,
    /// The PSU's battery.
    pub battery: Option<Battery>,
    /// The proximity module's ranges.
    pub proximity: Option<Proximity>,
    /// The IMU's reading.
    pub imu: Option<Imu>,
    /// The IMU's magnetic field.
    pub mag: Option<MagneticField>,
    /// The IMU's barometer.
    pub baro: Option<Barometer>,
    /// The IMU's GNSS fix.
    pub gnss: Option<GnssFix>,
    /// The gateway's status.
    pub status: Option<r2p_msgs::GatewayStatus>,
    /// The mirrored R2P topics' latest messages (`crate::endpoints::MIRRORED`).
    pub mirrored: [crate::Mirrored; MIRRORED.len()],
}

impl Latest {
    /// Nothing received yet: the initial value of a `static` (`Default` is not `const`).
    pub const NONE: Latest = Latest {
        odom: None,
        battery: None,
        proximity: None,
        imu: None,
        mag: None,
        baro: None,
        gnss: None,
        status: None,
        mirrored: [crate::Mirrored { bytes: [0; crate::app::MIRROR_MAX], len: 0, count: 0 };
            MIRRORED.len()],
    };
}

/// The gateway's ROS 2 node on a Zenoh session.
pub struct RosBridge {
    session: Session,
    domain: u32,
    namespace: heapless::String<MAX_NAMESPACE>,
    zid: [u8; 16],
    pubs: [Pub; topic::COUNT],
    cmd_key: KeyString,
    cmd: Option<(Twist2D, u64)>,
    cmd_pending: Option<Twist2D>,
    matching: Matching<REMOTE_SUBS>,
    demand: Demand,
    stats: RosStats,
}

/// Subscriber key expressions the bridge follows at once: as many as it publishes (one on
/// each key, or wildcards); more make every key count as listened to (r2p-zenoh's
/// `matching`). Each costs 8 B of static RAM, which the F407 image has little of.
pub const REMOTE_SUBS: usize = 16;

/// Longest namespace.
pub const MAX_NAMESPACE: usize = 48;

/// Zenoh lease the gateway announces (keep-alives every 2.5 s).
pub const LEASE_MS: u32 = 10_000;
/// Largest batch the gateway accepts from the router.
pub const RX_BATCH: u16 = 2048;

impl RosBridge {
    /// A bridge for the gateway's node in `cfg`'s domain and namespace. `None` if a key does
    /// not fit (a namespace longer than [`MAX_NAMESPACE`]).
    pub fn new(cfg: &RosConfig<'_>) -> Option<Self> {
        let namespace = heapless::String::try_from(cfg.namespace.trim_matches('/')).ok()?;
        let node =
            NodeInfo { domain: cfg.domain, namespace: &namespace, name: NODE_NAME, zid: cfg.zid };
        ros::token_key(&node, 0, Entity::Node, None)?;
        cmd_token(&node)?;
        let mut pubs: heapless::Vec<Pub, { topic::COUNT }> = heapless::Vec::new();
        for (i, (name, hz)) in TOPICS.iter().enumerate() {
            let _ = pubs.push(Pub {
                key: ros::topic_key(&node, name, &ros_type(i))?,
                gid: ros::gid(&pub_token(&node, i)?),
                seq: 0,
                period_us: if *hz == 0 { 0 } else { 1_000_000 / u64::from(*hz) },
                count: 0,
                next_us: 0,
            });
        }
        let pubs = pubs.into_array().ok()?;
        let cmd_key = ros::topic_key(&node, "/cmd_vel", &types::TWIST)?;
        let session = Session::new(Config { zid: cfg.zid, lease_ms: LEASE_MS, rx_batch: RX_BATCH });
        Some(Self {
            session,
            domain: cfg.domain,
            namespace,
            zid: cfg.zid,
            pubs,
            cmd_key,
            cmd: None,
            cmd_pending: None,
            matching: Matching::new(),
            demand: Demand::new(&[]),
            stats: RosStats::default(),
        })
    }

    /// The session's state.
    pub fn state(&self) -> State {
        self.session.state()
    }

    /// The counters.
    pub fn stats(&self) -> RosStats {
        RosStats {
            session: self.session.stats(),
            matching: self.matching.stats(),
            demand: self.demand.stats(),
            ..self.stats
        }
    }

    /// Follows `feeds` ([`crate::demand`]): the imports that feed the publishers, all wanted
    /// until the router says nobody listens.
    pub fn follow(&mut self, feeds: &[Feed<'_>]) {
        self.demand = Demand::new(feeds);
    }

    /// Bit `k`: the import of `feeds[k]` is wanted (for [`crate::demand::Follower::apply`]).
    pub fn wanted(&self) -> u32 {
        self.demand.wanted()
    }

    /// Whether publisher `i` ([`topic`]) has a subscriber behind the router: `None` until the
    /// router answered (and while the session is not open).
    pub fn matched(&self, i: usize) -> Option<bool> {
        matched(&self.session, &self.matching, i)
    }

    /// The key of publisher `i` ([`topic`]).
    pub fn key(&self, i: usize) -> &str {
        &self.pubs[i].key
    }

    /// A new link to the router: the INIT to send.
    pub fn connect(&mut self, now_us: u64, out: &mut [u8]) -> Result<usize, SessionError> {
        self.matching.reset();
        self.session.start(now_us, out)
    }

    /// One batch from the router: what to send back (the OPEN; once open, the declarations).
    pub fn receive(
        &mut self,
        now_us: u64,
        batch: &[u8],
        out: &mut [u8],
    ) -> Result<usize, SessionError> {
        let mut opened = false;
        let mut cmd = None;
        let mut bad = 0;
        let cmd_key = &self.cmd_key;
        let keys: [&str; topic::COUNT] = core::array::from_fn(|i| self.pubs[i].key.as_str());
        let matching = &mut self.matching;
        let n = self.session.receive(now_us, batch, out, |e| match e {
            Event::Opened => opened = true,
            Event::Sample { key, payload, .. } if key.is(cmd_key) => {
                match mapping::twist(payload) {
                    Ok(t) => cmd = Some(t),
                    Err(_) => bad += 1,
                }
            }
            Event::Sample { .. } => {}
            e => matching.on_event(&e, &keys),
        })?;
        self.stats.bad_cmd_vel += bad;
        if let Some(t) = cmd {
            self.stats.cmd_vel += 1;
            self.cmd = Some((t, now_us));
            self.cmd_pending = Some(t);
        }
        if opened {
            self.stats.opened += 1;
            return self.declare(now_us, &mut out[n..]).map(|m| n + m);
        }
        Ok(n)
    }

    /// The declarations, one frame each (the node and `/cmd_vel` first, then each publisher's
    /// key expression, the interest in its subscribers and its token: ~500 bytes a frame,
    /// ~4.4 KB in all). Tokens are rebuilt here, not kept: they go out once a session.
    fn declare(&mut self, now_us: u64, out: &mut [u8]) -> Result<usize, SessionError> {
        let node = NodeInfo {
            domain: self.domain,
            namespace: &self.namespace,
            name: NODE_NAME,
            zid: self.zid,
        };
        let (Some(node_token), Some(cmd_tok)) =
            (ros::token_key(&node, 0, Entity::Node, None), cmd_token(&node))
        else {
            return Err(SessionError::Overflow);
        };
        let cmd_key = &self.cmd_key;
        let mut n = self.session.send(now_us, out, |net| {
            net.declare_token(0, &node_token);
            net.declare_subscriber(1, cmd_key);
            net.declare_token(1 + topic::COUNT as u32, &cmd_tok);
        })?;
        for (i, p) in self.pubs.iter_mut().enumerate() {
            p.seq = 0;
            p.next_us = now_us;
            let token = pub_token(&node, i).ok_or(SessionError::Overflow)?;
            n += self.session.send(now_us, &mut out[n..], |net| {
                net.declare_keyexpr(1 + i as u16, &p.key);
                net.declare_interest(interest_id(i), 1 + i as u16);
                net.declare_token(1 + i as u32, &token);
            })?;
        }
        Ok(n)
    }

    /// Time passing: keep-alives, the lease, and each publisher's sample when due from
    /// `latest`; `stamp_ns` is the time the samples are stamped with (ns since the epoch).
    pub fn poll(
        &mut self,
        now_us: u64,
        stamp_ns: i64,
        latest: &Latest,
        out: &mut [u8],
    ) -> Result<usize, SessionError> {
        let mut n = self.session.poll(now_us, out)?;
        let (session, matching) = (&self.session, &self.matching);
        self.demand.update(now_us, |i| matched(session, matching, i));
        if self.session.state() != State::Open {
            return Ok(n);
        }
        let stamp = Stamp::from_ns(stamp_ns);
        let mut cdr = [0u8; mapping::size::MAX];
        for i in 0..topic::COUNT {
            if now_us < self.pubs[i].next_us {
                continue;
            }
            let len = match i {
                topic::ODOM => latest.odom.map(|o| mapping::odometry(&o, stamp, &mut cdr)),
                topic::BATTERY => {
                    latest.battery.map(|b| mapping::battery_state(&b, stamp, &mut cdr))
                }
                topic::IMU => latest.imu.map(|m| mapping::imu(&m, stamp, &mut cdr)),
                // A sensor with no data is not published (its R2P topic says why).
                topic::MAG => latest
                    .mag
                    .filter(|m| m.status == 0)
                    .map(|m| mapping::magnetic_field(&m, stamp, &mut cdr)),
                topic::PRESSURE => latest
                    .baro
                    .filter(|b| b.status == 0)
                    .map(|b| mapping::fluid_pressure(&b, stamp, &mut cdr)),
                topic::GNSS => latest
                    .gnss
                    .filter(|g| g.status == 0)
                    .map(|g| mapping::nav_sat_fix(&g, stamp, &mut cdr)),
                topic::STATUS => latest.status.and_then(|s| {
                    let t = r2p_type("GatewayStatus")?;
                    let mut packed = [0u8; r2p_msgs::GatewayStatus::SIZE];
                    s.encode(&mut packed).ok()?;
                    Some(r2p_zenoh::cdr::packed_to_cdr(t.fields, &packed, &mut cdr))
                }),
                i if i >= topic::MIRRORED0 => {
                    let m = &latest.mirrored[i - topic::MIRRORED0];
                    if m.count == self.pubs[i].count {
                        continue; // nothing new
                    }
                    self.pubs[i].count = m.count;
                    r2p_type(MIRRORED[i - topic::MIRRORED0].1)
                        .map(|t| r2p_zenoh::cdr::packed_to_cdr(t.fields, m.packed(), &mut cdr))
                }
                _ => latest.proximity.map(|p| {
                    let ch = i - topic::RANGE0;
                    let frame: &str = ["range_0", "range_1", "range_2", "range_3"][ch];
                    mapping::range(&p, ch, &RANGER, frame, stamp, &mut cdr)
                }),
            };
            let Some(Ok(len)) = len else { continue };
            let p = &mut self.pubs[i];
            p.next_us = p.next_us.max(now_us.saturating_sub(p.period_us)) + p.period_us;
            // The write filter (the session is open here): nobody would receive it.
            if !self.matching.sends(i) {
                self.stats.filtered += 1;
                continue;
            }
            p.seq += 1;
            let att = ros::attachment(p.seq, stamp_ns, &p.gid);
            n += self.session.send(now_us, &mut out[n..], |net| {
                net.put(1 + i as u16, &cdr[..len], Some(&att))
            })?;
            self.stats.published += 1;
        }
        Ok(n)
    }

    /// The velocity command to apply now: a new `/cmd_vel`, or a zero command once when none
    /// came for [`CMD_WATCHDOG_US`] (the base stops); `None` when nothing changes.
    pub fn take_cmd(&mut self, now_us: u64) -> Option<Twist2D> {
        if let Some(t) = self.cmd_pending.take() {
            return Some(t);
        }
        match self.cmd {
            Some((_, at)) if now_us.saturating_sub(at) > CMD_WATCHDOG_US => {
                self.cmd = None;
                self.stats.watchdog_stops += 1;
                Some(Twist2D::default())
            }
            _ => None,
        }
    }

    /// Whether ROS is driving the base (a `/cmd_vel` within the watchdog): the robot file's
    /// teleop script stays quiet meanwhile.
    pub fn driving(&self) -> bool {
        self.cmd.is_some()
    }
}

/// Whether publisher `i` has a subscriber, as far as an open session knows.
fn matched(session: &Session, matching: &Matching<REMOTE_SUBS>, i: usize) -> Option<bool> {
    match session.state() {
        State::Open => matching.matched(i),
        _ => None,
    }
}

/// Publisher `i`'s liveliness token.
fn pub_token(node: &NodeInfo<'_>, i: usize) -> Option<KeyString> {
    let qos = if i == topic::STATUS || i >= topic::MIRRORED0 { DEFAULT_QOS } else { SENSOR_QOS };
    ros::token_key(node, 1 + i as u32, Entity::Publisher, Some((TOPICS[i].0, &ros_type(i), qos)))
}

/// The `/cmd_vel` subscription's liveliness token.
fn cmd_token(node: &NodeInfo<'_>) -> Option<KeyString> {
    ros::token_key(
        node,
        1 + topic::COUNT as u32,
        Entity::Subscription,
        Some(("/cmd_vel", &types::TWIST, DEFAULT_QOS)),
    )
}
