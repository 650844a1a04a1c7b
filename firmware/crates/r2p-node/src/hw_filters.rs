//! The acceptance filters a node programs into its CAN controller: the frames it can use are
//! the syncs, every node's management stream and the streams it subscribed to; everything else
//! it would only count and drop. bxCAN checks them in hardware, so the MCU never takes an
//! interrupt or a FIFO slot for another module's traffic. The node's own checks stay (the
//! software filter): with more streams than banks, [`rtcan::filter_banks::fit`] widens the
//! filters rather than lose a wanted frame.

use r2p_management::MANAGEMENT_INDEX;
use rtcan::controller::Filter;
use rtcan::filter_banks::{fit_one, Fit, ID_BITS};
use rtcan::id::{FRAGMENT_BITS, MAX_SYNC_SENDER};
use rtcan::MessageId;

/// Filter banks a node uses: all 14 of the F103's bxCAN (CAN1's share on the F407).
pub const BANKS: usize = 14;

/// Sync frames: laxity 0, message IDs 0x00–0xFF, fragment 0–15 (the sender's master rank).
pub const SYNCS: Filter =
    Filter { value: 0, mask: ID_BITS & !(0xFF << FRAGMENT_BITS) & !(MAX_SYNC_SENDER as u32) };

/// Every node's management stream (message ID low byte = `MANAGEMENT_INDEX`).
pub const MANAGEMENT: Filter = Filter::message_low_bits(MANAGEMENT_INDEX as u16, 8);

/// The banks for a node subscribed to `streams`: `(banks, used)`; `used` = 0 never happens
/// (syncs and management always take one), so the slice is what to program.
pub fn banks(streams: impl Iterator<Item = MessageId>) -> ([Filter; BANKS], Fit) {
    let mut out = [Filter::ACCEPT_ALL; BANKS];
    let mut fit = Fit { used: 0, widened: false };
    for w in [SYNCS, MANAGEMENT].into_iter().chain(streams.map(Filter::stream)) {
        fit = fit_one(&mut out, fit, w);
    }
    (out, fit)
}

/// A cheap fingerprint of a set of subscribed streams (order-independent), to reprogram the
/// banks only when it changes.
pub fn fingerprint(streams: impl Iterator<Item = MessageId>) -> u32 {
    streams.fold(0x9E37_79B9, |h, m| {
        h.wrapping_add((u32::from(m.0) | 0x1_0000).wrapping_mul(0x85EB_CA6B).rotate_left(13))
    })
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use rtcan::{FrameId, Laxity};

    fn raw(laxity: u8, message: u16, fragment: u8) -> u32 {
        FrameId { laxity: Laxity::from_code(laxity), message: MessageId(message), fragment }
            .to_raw()
    }

    r2p_testkit::suite! {
        fn a_node_passes_syncs_management_and_its_streams_only() {
            let (b, fit) = banks([MessageId(0x4303), MessageId(0x4501)].into_iter());
            assert_eq!(fit, Fit { used: 4, widened: false });
            let pass = |id| b[..fit.used].iter().any(|f| f.accepts(id));
            assert!(pass(raw(0, 0x0045, 0)) && pass(raw(0, 0x0045, 15)), "syncs of every rank");
            assert!(pass(raw(63, 0x4400, 3)) && pass(raw(63, 0x0100, 0)), "management");
            assert!(pass(raw(9, 0x4303, 2)) && pass(raw(0, 0x4501, 0)), "subscribed");
            assert!(!pass(raw(9, 0x4302, 2)) && !pass(raw(0, 0x4502, 0)), "other streams");
            assert!(!pass(raw(0, 0x0045, 16)) && !pass(raw(5, 0x0045, 0)), "not syncs");
        }

        fn more_streams_than_banks_widen_never_lose() {
            let streams = (0..20u16).map(|k| MessageId(0x4201 + k));
            let (b, fit) = banks(streams.clone());
            assert!(fit.widened && fit.used <= BANKS);
            for m in streams {
                assert!(b[..fit.used].iter().any(|f| f.accepts(raw(9, m.0, 1))));
            }
        }

        fn the_fingerprint_ignores_order_and_sees_changes() {
            let a = fingerprint([MessageId(1), MessageId(2)].into_iter());
            assert_eq!(a, fingerprint([MessageId(2), MessageId(1)].into_iter()));
            assert_ne!(a, fingerprint([MessageId(1)].into_iter()));
            assert_ne!(a, fingerprint([MessageId(1), MessageId(3)].into_iter()));
        }
    }
}
