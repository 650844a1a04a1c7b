//! The master's calendar places each stream in the tightest free block that holds it (best-fit
//! buddy placement, docs/rtcan.md "HRT registration"), so a half-used slot is filled before an
//! empty one is broken up: slots that stay whole are what a later fast stream (period 1) needs.

use rtcan::schedule::Reject;
use rtcan::{MessageId, Scheduler, TxQueue};

#[test]
fn a_half_used_slot_is_filled_before_an_empty_one_is_broken_up() {
    let mut s: Scheduler<8> = Scheduler::new(2, 16);
    assert!(s.is_empty());
    let a = s.register(MessageId(0x4101), 2).unwrap();
    assert!(!s.is_empty() && s.len() == 1);
    let b = s.register(MessageId(0x4201), 2).unwrap();
    assert_eq!(b.slot, a.slot, "the other half of A's slot");
    assert_ne!(b.offset, a.offset);
    // The second slot is still whole: a stream of every cycle fits.
    let c = s.register(MessageId(0x4301), 1).unwrap();
    assert_ne!(c.slot, a.slot);
    assert_eq!(s.register(MessageId(0x4401), 4), Err(Reject::Full));
}

#[test]
fn period_4_streams_pack_a_slot_before_opening_another() {
    let mut s: Scheduler<8> = Scheduler::new(2, 16);
    let first = s.register(MessageId(0x4101), 4).unwrap();
    // A period-2 stream next: into the free half of the first slot, not the empty second slot.
    let half = s.register(MessageId(0x4201), 2).unwrap();
    assert_eq!(half.slot, first.slot);
    let quarter = s.register(MessageId(0x4301), 4).unwrap();
    assert_eq!(quarter.slot, first.slot, "the last quarter of the first slot");
    assert!(s.register(MessageId(0x4401), 1).is_ok(), "the second slot stayed whole");
}

#[test]
fn an_empty_transmit_queue_says_so() {
    let mut q: TxQueue<4> = TxQueue::new(rtcan::LaxityEncoding::Linear { tick_us: 100 });
    assert!(q.is_empty());
    q.push_message(MessageId(0x4301), &[1], rtcan::Urgency::Nrt).unwrap();
    assert!(!q.is_empty());
}

#[test]
fn a_tight_quarter_elsewhere_is_taken_before_a_free_half_is_broken() {
    // Sculpt two slots (streams leave, as nodes do at a master change): slot X holds one
    // period-2 stream and a free half; slot Y has one free quarter. A new period-4 stream must
    // take Y's quarter, so the free half stays for a period-2 stream.
    let mut s: Scheduler<8> = Scheduler::new(2, 16);
    let id = |n: u16| MessageId(0x4001 + (n << 8));
    let a = s.register(id(1), 2).unwrap();
    let b = s.register(id(2), 2).unwrap();
    assert_eq!(a.slot, b.slot);
    let c = s.register(id(3), 2).unwrap();
    s.register(id(4), 4).unwrap();
    s.register(id(5), 4).unwrap();
    assert!(s.remove(id(3)).is_some());
    let f = s.register(id(6), 4).unwrap();
    assert_eq!(f.slot, c.slot, "the quarter beside the others");
    assert!(s.remove(id(2)).is_some());
    // Now: a's slot has a free half; c's slot has one free quarter.
    let g = s.register(id(7), 4).unwrap();
    assert_eq!(g.slot, c.slot, "the tight quarter, not a piece of the free half");
    assert!(s.register(id(8), 2).is_ok(), "the free half is whole");
}
