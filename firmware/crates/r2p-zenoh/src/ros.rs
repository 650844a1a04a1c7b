//! rmw_zenoh's conventions (ROS 2 Jazzy and later; its docs/design.md,
//! `liveliness_utils.cpp`, `attachment_helpers.cpp`): what makes a Zenoh key a ROS 2 topic
//! that `ros2 topic echo` reads and `ros2 topic list` lists.
//!
//! - a topic's key: `<domain>/<namespace>/<topic>/<pkg>::msg::dds_::<Type>_/RIHS01_<hash>`
//!   (no leading or trailing slashes);
//! - a liveliness token per node, publisher and subscription:
//!   `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<NN|MP|MS>/<enclave>/<namespace>/<node>`
//!   then, for publishers and subscriptions, `/<topic>/<type>/<hash>/<qos>`, with every `/`
//!   inside a name written `%` (so the empty namespace `/` is `%`);
//! - on every sample, an attachment: sequence number (i64, from 1), source timestamp (i64 ns
//!   since the Unix epoch), the publisher's 16-byte GID (a length byte 16, then the bytes);
//!   the GID is XXH3-128 of the publisher's token key (low 64 bits, then high, little-endian).

use core::fmt::Write;

use heapless::String;

use crate::session::MAX_KEY;

/// A ROS 2 message type as rmw_zenoh names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RosType {
    /// `pkg::msg::dds_::Type_`.
    pub dds_name: &'static str,
    /// `RIHS01_<sha256 hex>`.
    pub hash: &'static str,
}

/// A key expression, built in place.
pub type KeyString = String<MAX_KEY>;

/// What a liveliness token announces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entity {
    /// The node.
    Node,
    /// A publisher.
    Publisher,
    /// A subscription.
    Subscription,
}

/// The default QoS as rmw_zenoh writes it in a token (reliable, volatile, keep last 10, no
/// deadline, lifespan or liveliness lease): every field empty means "the default".
pub const DEFAULT_QOS: &str = "::,:,:,:,,";
/// Best effort (rmw's `RMW_QOS_POLICY_RELIABILITY_BEST_EFFORT` = 2), the rest default: the
/// sensor topics' QoS.
pub const SENSOR_QOS: &str = "2::,:,:,:,,";

/// The gateway's node as ROS 2 sees it.
#[derive(Clone, Copy, Debug)]
pub struct NodeInfo<'a> {
    /// ROS domain ID.
    pub domain: u32,
    /// Namespace without slashes at either end ("" for none), e.g. `robot1`.
    pub namespace: &'a str,
    /// The node's name.
    pub name: &'a str,
    /// The session's Zenoh ID.
    pub zid: [u8; 16],
}

fn trim(s: &str) -> &str {
    s.trim_matches('/')
}

/// The key of `topic` (e.g. `/odom` or `odom`) of type `ty` in the node's domain and namespace.
pub fn topic_key(node: &NodeInfo<'_>, topic: &str, ty: &RosType) -> Option<KeyString> {
    let mut k = KeyString::new();
    write!(k, "{}/", node.domain).ok()?;
    if !trim(node.namespace).is_empty() {
        write!(k, "{}/", trim(node.namespace)).ok()?;
    }
    write!(k, "{}/{}/{}", trim(topic), ty.dds_name, ty.hash).ok()?;
    Some(k)
}

/// Writes `s` with `/` as `%` (rmw_zenoh's mangling).
fn mangled(k: &mut KeyString, s: &str) -> Option<()> {
    for c in s.chars() {
        k.push(if c == '/' { '%' } else { c }).ok()?;
    }
    Some(())
}

/// The liveliness token of the node (`entity_id` 0, `topic` None) or of one of its
/// publishers or subscriptions (`entity_id` > 0; the topic, its type and its QoS).
pub fn token_key(
    node: &NodeInfo<'_>,
    entity_id: u32,
    entity: Entity,
    topic: Option<(&str, &RosType, &str)>,
) -> Option<KeyString> {
    let mut k = KeyString::new();
    let kind = match entity {
        Entity::Node => "NN",
        Entity::Publisher => "MP",
        Entity::Subscription => "MS",
    };
    write!(
        k,
        "@ros2_lv/{}/{:x}/0/{}/{}/%/",
        node.domain,
        u128::from_le_bytes(node.zid),
        entity_id,
        kind
    )
    .ok()?;
    k.push('%').ok()?;
    if !trim(node.namespace).is_empty() {
        mangled(&mut k, trim(node.namespace))?;
    }
    k.push('/').ok()?;
    mangled(&mut k, node.name)?;
    if let Some((topic, ty, qos)) = topic {
        k.push_str("/%").ok()?;
        if !trim(node.namespace).is_empty() {
            mangled(&mut k, trim(node.namespace))?;
            k.push('%').ok()?;
        }
        mangled(&mut k, trim(topic))?;
        write!(k, "/{}/{}/{}", ty.dds_name, ty.hash, qos).ok()?;
    }
    Some(k)
}

/// A publisher's GID: XXH3-128 of its token key, low half then high half, little-endian.
pub fn gid(token_key: &str) -> [u8; 16] {
    let h = xxhash_rust::xxh3::xxh3_128(token_key.as_bytes());
    let mut g = [0u8; 16];
    g[..8].copy_from_slice(&(h as u64).to_le_bytes());
    g[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    g
}

/// Bytes of an attachment.
pub const ATTACHMENT_LEN: usize = 33;

/// rmw_zenoh's attachment: zenoh-ext serialization of (i64 sequence number, i64 source
/// timestamp in ns, [u8; 16] GID as a sequence: LEB128 length 16, then the bytes).
pub fn attachment(sequence: i64, timestamp_ns: i64, gid: &[u8; 16]) -> [u8; ATTACHMENT_LEN] {
    let mut a = [0u8; ATTACHMENT_LEN];
    a[..8].copy_from_slice(&sequence.to_le_bytes());
    a[8..16].copy_from_slice(&timestamp_ns.to_le_bytes());
    a[16] = 16;
    a[17..].copy_from_slice(gid);
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    const ODOM: RosType = crate::types::ODOMETRY;

    fn node(ns: &'static str) -> NodeInfo<'static> {
        let mut zid = [0u8; 16];
        zid[0] = 0xAB;
        zid[15] = 0x80;
        NodeInfo { domain: 7, namespace: ns, name: "r2p_gateway", zid }
    }

    #[test]
    fn topic_keys_are_domain_namespace_topic_type_hash() {
        assert_eq!(
            topic_key(&node(""), "/odom", &ODOM).unwrap().as_str(),
            "7/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0"
        );
        assert!(topic_key(&node("/robot1/"), "odom", &ODOM)
            .unwrap()
            .starts_with("7/robot1/odom/nav_msgs::msg::dds_::Odometry_/"));
    }

    #[test]
    fn tokens_mangle_slashes_and_carry_topic_type_hash_qos() {
        let n = node("");
        let zid = "800000000000000000000000000000ab";
        assert_eq!(
            token_key(&n, 0, Entity::Node, None).unwrap().as_str(),
            alloc_free_concat(&["@ros2_lv/7/", zid, "/0/0/NN/%/%/r2p_gateway"])
        );
        let t = token_key(&n, 3, Entity::Publisher, Some(("/odom", &ODOM, DEFAULT_QOS))).unwrap();
        assert_eq!(
            t.as_str(),
            alloc_free_concat(&[
                "@ros2_lv/7/",
                zid,
                "/0/3/MP/%/%/r2p_gateway/%odom/nav_msgs::msg::dds_::Odometry_/",
                ODOM.hash,
                "/::,:,:,:,,"
            ])
        );
        let t =
            token_key(&node("a/b"), 1, Entity::Subscription, Some(("cmd_vel", &ODOM, DEFAULT_QOS)))
                .unwrap();
        assert!(t.contains("/MS/%/%a%b/r2p_gateway/%a%b%cmd_vel/"), "{t}");
    }

    fn alloc_free_concat(parts: &[&str]) -> String<512> {
        let mut s = String::new();
        for p in parts {
            s.push_str(p).unwrap();
        }
        s
    }

    #[test]
    fn attachments_are_33_bytes_seq_time_gid() {
        let g = gid("@ros2_lv/0/x");
        let a = attachment(1, 1_700_000_000_123_456_789, &g);
        assert_eq!(&a[..8], &1i64.to_le_bytes());
        assert_eq!(&a[8..16], &1_700_000_000_123_456_789i64.to_le_bytes());
        assert_eq!(a[16], 16);
        assert_eq!(&a[17..], &g);
        assert_ne!(gid("@ros2_lv/0/y"), g);
    }
}
