//! The base controller's outputs that ROS 2 shows (`/odom`, `/range_N`), imported from the bus
//! when another node runs the base controller (`base_controller` off). When the gateway runs
//! it, its application hands them over directly instead: a node imports a topic once, and the
//! base controller on the gateway exports `odom` and imports the ranges itself.
//!
//! Made at boot in a [`RemoteBaseStorage`] of cells, as [`crate::Storage`]: a `static` on the
//! MCU, leaked per emulated board on the host.

use r2p_middleware::{pool_size, Error};
use r2p_module::{Inbound, InboundCell, TopicNode};
use r2p_msgs::{Odometry, Proximity};
use r2p_node::{Import, NodeError};

use crate::demand::Feed;
use crate::ros::topic;

/// The base controller's odometry.
pub const ODOM_TOPIC: &str = "odom";

/// The gateway's one subscriber keeps the latest two of each.
const QUEUE: usize = 2;
const POOL: usize = pool_size(&[QUEUE], 1);

/// The two imports and the latest message of each.
pub struct RemoteBase<'a> {
    odom: Inbound<'a, Odometry, POOL, 1, QUEUE>,
    ranges: Inbound<'a, Proximity, POOL, 1, QUEUE>,
    latest: (Option<Odometry>, Option<Proximity>),
}

/// Room for one [`RemoteBase`]: declare it `static` on the MCU, then build it once.
pub struct RemoteBaseStorage {
    odom: InboundCell<Odometry, POOL, 1, QUEUE>,
    ranges: InboundCell<Proximity, POOL, 1, QUEUE>,
}

impl Default for RemoteBaseStorage {
    fn default() -> Self {
        Self::new()
    }
}

impl RemoteBaseStorage {
    /// Empty storage.
    pub const fn new() -> Self {
        Self { odom: InboundCell::new(), ranges: InboundCell::new() }
    }

    /// `odom` and the proximity module's ranges, `ranges` (the topic the base controller's
    /// `proximity_instance` names).
    ///
    /// # Panics
    /// If called twice on one storage (each cell is initialised once).
    pub fn build(&'static self, ranges: &'static str) -> RemoteBase<'static> {
        let built = (|| -> Result<_, Error> {
            Ok(RemoteBase {
                odom: self.odom.build(ODOM_TOPIC, Odometry::default())?,
                ranges: self.ranges.build(ranges, Proximity::default())?,
                latest: (None, None),
            })
        })();
        built.expect("the imports are sized for their endpoints")
    }
}

impl<'a> RemoteBase<'a> {
    /// Imports both topics on `node`.
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        node.import(self.odom.remote)?;
        node.import(self.ranges.remote)?;
        Ok(())
    }

    /// Both imports as the ROS side follows them ([`crate::demand`]): `odom` feeds `/odom`, the
    /// ranges `/range_0` … `/range_3`.
    pub fn feeds(&self) -> [Feed<'a>; 2] {
        let ranges = (0..4).fold(0, |m, ch| m | 1 << (topic::RANGE0 + ch));
        [
            Feed { topic: self.odom.remote.topic(), ros: 1 << topic::ODOM },
            Feed { topic: self.ranges.remote.topic(), ros: ranges },
        ]
    }

    /// The latest odometry and ranges received so far (reading what came since the last call).
    pub fn latest(&mut self) -> (Option<Odometry>, Option<Proximity>) {
        while let Some(o) = self.odom.subscriber.try_recv() {
            self.latest.0 = Some(*o);
        }
        while let Some(r) = self.ranges.subscriber.try_recv() {
            self.latest.1 = Some(*r);
        }
        self.latest
    }
}

#[cfg(any(test, feature = "std"))]
impl RemoteBase<'static> {
    /// A fresh one on the host (its storage is leaked: one per emulated board).
    pub fn leak(ranges: &'static str) -> Self {
        std::boxed::Box::leak(std::boxed::Box::new(RemoteBaseStorage::new())).build(ranges)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use r2p_msgs::R2pMessage;

    #[test]
    fn what_the_bus_brings_is_the_latest_until_something_newer_comes() {
        let mut b = RemoteBase::leak("proximity2/ranges");
        assert_eq!(b.latest(), (None, None));
        assert_eq!(b.ranges.remote.topic(), "proximity2/ranges");
        assert_eq!(b.odom.remote.topic(), "odom");
        let mut buf = [0u8; 64];
        for x in [1.0, 2.0] {
            let n = Odometry { x, ..Odometry::default() }.encode(&mut buf).unwrap();
            b.odom.remote.publish_bytes(&buf[..n]).unwrap();
        }
        let r = Proximity { distance: [0.5; 4], ..Proximity::default() };
        let n = r.encode(&mut buf).unwrap();
        b.ranges.remote.publish_bytes(&buf[..n]).unwrap();
        let (odom, ranges) = b.latest();
        assert_eq!(odom.map(|o| o.x), Some(2.0), "the newest");
        assert_eq!(ranges, Some(r));
        assert_eq!(b.latest().0.map(|o| o.x), Some(2.0), "kept while nothing newer comes");
    }

    #[test]
    fn the_node_imports_both() {
        let b = RemoteBase::leak("proximity/ranges");
        let config = r2p_node::NodeConfig::new([7; 12], "gateway");
        let mut node =
            r2p_node::Node::<'static, 1, 2, 8, 1, 64>::new(config, &r2p_node::NoParams).unwrap();
        b.register(&mut node).unwrap();
        assert!(node.import_state(0).is_some() && node.import_state(1).is_some());
        assert!(node.import_state(2).is_none());
    }
}
