//! A merged filter is the narrowest that accepts what both accepted (docs/rtcan.md,
//! "Acceptance filters"): it leaves free only the bits where the two differ, so the MCU takes
//! as few unwanted frames as the banks allow; the management filter takes every node's
//! management stream and nothing else.

use rtcan::controller::Filter;
use rtcan::{FrameId, Laxity, MessageId};

fn raw(laxity: u8, message: u16, fragment: u8) -> u32 {
    FrameId { laxity: Laxity::from_code(laxity), message: MessageId(message), fragment }.to_raw()
}

#[test]
fn two_streams_merge_into_a_filter_free_only_where_they_differ() {
    // 0x4301 and 0x4303 differ in bit 1 only.
    let f = Filter::stream(MessageId(0x4301)).merge(Filter::stream(MessageId(0x4303)));
    for m in [0x4301, 0x4303] {
        assert!(f.accepts(raw(9, m, 2)) && f.accepts(raw(0, m, 0)), "{m:#x} kept");
    }
    for m in [0x4300, 0x4302, 0x0301, 0x4201, 0xC301] {
        assert!(!f.accepts(raw(9, m, 2)), "{m:#x} needlessly let through");
    }
    assert_eq!(f.free_bits(), Filter::stream(MessageId(0)).free_bits() + 1);
}

#[test]
fn the_management_filter_takes_every_nodes_management_stream_only() {
    let f = Filter::message_low_bits(0, 8);
    for node in [1u16, 0x42, 0xFE] {
        assert!(f.accepts(raw(63, node << 8, 0)) && f.accepts(raw(5, node << 8, 3)));
        assert!(!f.accepts(raw(63, node << 8 | 1, 0)), "stream 1 of node {node:#x}");
    }
    // Another low byte: a node's stream 3 of any node.
    let g = Filter::message_low_bits(3, 8);
    assert!(
        g.accepts(raw(9, 0x4503, 1))
            && !g.accepts(raw(9, 0x4500, 1))
            && !g.accepts(raw(9, 0x4513, 1))
    );
}

#[test]
fn a_filter_already_covered_takes_no_bank() {
    use rtcan::filter_banks::{fit, Fit};
    let s = Filter::stream(MessageId(0x4301));
    let mut out = [Filter::ACCEPT_ALL; 4];
    // Two imports of one stream, and a stream inside a merged filter.
    assert_eq!(fit(&[s, s], &mut out), Fit { used: 1, widened: false });
    let merged = s.merge(Filter::stream(MessageId(0x4303)));
    assert_eq!(
        fit(&[merged, Filter::stream(MessageId(0x4303)), s], &mut out),
        Fit { used: 1, widened: false }
    );
    assert!(merged.covers(&s) && !s.covers(&merged));
}

#[test]
fn with_the_banks_full_the_closest_pair_is_merged() {
    use rtcan::filter_banks::{fit, Fit};
    let (far, a, b) = (MessageId(0x1005), MessageId(0x4301), MessageId(0x4303));
    let mut out = [Filter::ACCEPT_ALL; 2];
    let fit = fit(&[Filter::stream(far), Filter::stream(a), Filter::stream(b)], &mut out);
    assert_eq!(fit, Fit { used: 2, widened: true });
    // 0x4301 and 0x4303 share a bank (one free bit); 0x1005 keeps its own, exact.
    assert!(out.contains(&Filter::stream(far)), "{out:?}");
    assert!(out.contains(&Filter::stream(a).merge(Filter::stream(b))), "{out:?}");
}
