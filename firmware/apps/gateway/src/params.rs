//! The gateway's network parameters: the table its node serves over the bus (PARAM_GET /
//! PARAM_SET, ranges checked by the store), kept in flash by the image, as every module's.
//!
//! Addresses are `u32`s, a.b.c.d as `(a << 24) | (b << 16) | (c << 8) | d`, the way the
//! management protocol carries numbers. They take effect at the next boot (`r2p param … reboot`
//! after setting them): a gateway that changed its address under a connected client would cut
//! the client off mid-session.
//!
//! Another application's parameters may follow on the same node (the gateway also runs the
//! base controller): [`followed_by`] builds the joined table, the other application reads its
//! part through an [`Offset`] view, and [`Net::read`] takes the index of the first network
//! parameter (0 in the gateway's tables: its own come first, so a gateway's stored parameters
//! keep their indices when another application's are added after them).

use r2p_management::message::{ParamFault, Value};
use r2p_node::{Param, ParamStore, Typed};

/// Take the address from DHCP (static address if no lease comes within `dhcp_wait_ms`).
pub const DHCP: u16 = 0;
/// How long to wait for a DHCP lease before using the static address, ms.
pub const DHCP_WAIT_MS: u16 = 1;
/// Static IPv4 address.
pub const IP: u16 = 2;
/// Static address's prefix length (24 = netmask 255.255.255.0).
pub const PREFIX_LEN: u16 = 3;
/// Static default router (0: none).
pub const ROUTER: u16 = 4;
/// TCP port of the socketcand server.
pub const TCP_PORT: u16 = 5;
/// The Zenoh router's IPv4 address (0: no ROS 2 over Zenoh), docs/ros2.md.
pub const ZENOH_ROUTER: u16 = 6;
/// The Zenoh router's TCP port (7447: rmw_zenoh's router).
pub const ZENOH_PORT: u16 = 7;
/// ROS domain ID of the gateway's ROS 2 node and topics (as `ROS_DOMAIN_ID`).
pub const ROS_DOMAIN: u16 = 8;
/// The gateway runs the robot's base controller (r2p-app-base, whose parameters come first in
/// the gateway image's table); off when another node on the bus runs it (docs/ros2.md).
pub const BASE_CONTROLLER: u16 = 9;

/// Number of the gateway's own parameters.
pub const COUNT: usize = 10;

/// 192.168.1.50: a static address in the most common home/lab subnet.
pub const DEFAULT_IP: u32 = u32::from_be_bytes([192, 168, 1, 50]);

/// The network parameters with their defaults and ranges (index = position = the constants
/// above, counted from the first network parameter).
pub const DEFAULTS: [Param; COUNT] = [
    Param::bool("dhcp", true),
    Param::u32("dhcp_wait_ms", 10_000, 1_000, 600_000),
    Param::u32("ip", DEFAULT_IP, 0, u32::MAX),
    Param::u32("prefix_len", 24, 1, 31),
    Param::u32("router", 0, 0, u32::MAX),
    Param::u32("tcp_port", r2p_socketcand::DEFAULT_PORT as u32, 1, 65_535),
    Param::u32("zenoh_router", 0, 0, u32::MAX),
    Param::u32("zenoh_port", 7447, 1, 65_535),
    Param::u32("ros_domain", 0, 0, 232),
    Param::bool("base_controller", true),
];

/// Whether the gateway runs the base controller, from `store` whose gateway parameters start
/// at index `first` (as [`Net::read`]'s).
pub fn base_controller(store: &dyn ParamStore, first: u16) -> bool {
    Typed::new(&Offset { store, first }, &DEFAULTS).bool(BASE_CONTROLLER)
}

/// [`DEFAULTS`] followed by `other` (`T` = [`COUNT`] + `B`, checked when evaluated): the table
/// of a node that runs another application beside the gateway's, whose parameters start at
/// index [`COUNT`].
pub const fn followed_by<const B: usize, const T: usize>(other: [Param; B]) -> [Param; T] {
    assert!(T == B + COUNT, "the joined table holds both tables");
    let mut out = [DEFAULTS[0]; T];
    let mut i = 0;
    while i < T {
        out[i] = if i < COUNT { DEFAULTS[i] } else { other[i - COUNT] };
        i += 1;
    }
    out
}

/// The network settings as the network stack applies them at boot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Net {
    /// Ask DHCP first.
    pub dhcp: bool,
    /// How long to wait for a lease before the static address, ms.
    pub dhcp_wait_ms: u32,
    /// Static address.
    pub ip: [u8; 4],
    /// Static address's prefix length.
    pub prefix_len: u8,
    /// Static default router, if any.
    pub router: Option<[u8; 4]>,
    /// The socketcand server's TCP port.
    pub tcp_port: u16,
    /// The Zenoh router (address, port), if ROS 2 is on.
    pub zenoh: Option<([u8; 4], u16)>,
    /// ROS domain ID.
    pub ros_domain: u32,
}

impl Net {
    /// The settings from `store`, whose network parameters start at index `first` (0 when
    /// the gateway's table is the node's only one); defaults where the store lacks one.
    pub fn read(store: &dyn ParamStore, first: u16) -> Self {
        // `Typed` falls back to DEFAULTS by index: read through a view from `first` on.
        let view = Offset { store, first };
        let t2 = Typed::new(&view, &DEFAULTS);
        let router = t2.u32(ROUTER);
        Self {
            dhcp: t2.bool(DHCP),
            dhcp_wait_ms: t2.u32(DHCP_WAIT_MS),
            ip: t2.u32(IP).to_be_bytes(),
            prefix_len: t2.u32(PREFIX_LEN) as u8,
            router: (router != 0).then(|| router.to_be_bytes()),
            tcp_port: t2.u32(TCP_PORT) as u16,
            zenoh: match t2.u32(ZENOH_ROUTER) {
                0 => None,
                ip => Some((ip.to_be_bytes(), t2.u32(ZENOH_PORT) as u16)),
            },
            ros_domain: t2.u32(ROS_DOMAIN),
        }
    }
}

/// A store seen from its parameter `first` on: the view of one application's part of a joined
/// table (index 0 of the view is `first` of the store).
pub struct Offset<'a> {
    /// The whole table.
    pub store: &'a dyn ParamStore,
    /// Index in `store` of the view's first parameter.
    pub first: u16,
}

impl ParamStore for Offset<'_> {
    fn get(&self, index: u16) -> Result<Value, ParamFault> {
        self.store.get(index.saturating_add(self.first))
    }
    fn set(&self, index: u16, value: Value) -> Result<Value, ParamFault> {
        self.store.set(index.saturating_add(self.first), value)
    }
}
