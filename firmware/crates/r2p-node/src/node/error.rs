//! The one error type of the node's API: every refusal says what was wrong, so that a module's
//! `main` can report it rather than guess.

use rtcan::cycle::ConfigError;

/// Why the node refused a configuration, export, import or request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeError {
    /// The module name is longer than 16 characters or not printable ASCII.
    BadName,
    /// A topic name is empty, longer than 32 characters or uses characters outside `A-Za-z0-9_/`.
    BadTopicName,
    /// No room for another export or import (the node's const capacities, at most 255 exports).
    TooMany,
    /// A topic with this name is already exported (or imported).
    DuplicateTopic,
    /// Messages of this size cannot go through the node's buffers.
    TooLarge {
        /// The message size.
        size: usize,
        /// The largest size the node takes.
        max: usize,
    },
    /// A synchronous real-time (HRT) publisher's period is not a power of two (1…256) of
    /// communication cycles.
    HrtPeriod {
        /// The publisher's period.
        period_us: u32,
        /// The cycle's length.
        cycle_us: u32,
    },
    /// The rank is above 15 (`rtcan::failover::MAX_RANK`).
    BadRank,
    /// A rank for a node built without the bus master's side (`Node<…, MASTER = false>`: a
    /// module image that cannot become master; build it with the master's side).
    NotMasterCapable,
    /// The cycle configuration is invalid (slots too short, bit rate, slot count).
    BadCycle(ConfigError),
    /// `NodeConfig::hrt_blocks` > 0 needs a node built with the feature `framed-reservations`
    /// and 1 … `rtcan::layout::MAX_BLOCKS` blocks, each with room for its share of `hrt_slots`.
    BadBlocks(u8),
    /// The transmit queue is full: the management message was not queued.
    TxFull,
    /// No import has this index (indices are what [`Node::import`](crate::Node::import)
    /// returned).
    NoImport,
}
