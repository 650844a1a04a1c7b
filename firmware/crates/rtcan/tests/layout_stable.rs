//! Frame-sized reservations (docs/rtcan.md "Capacity"): whatever streams come and go, the
//! master's layout never lets two reservations overlap or leave their block's share, never
//! moves a slot a stream still uses (every node sends at its slot's offset; a slot grows only
//! when nothing follows it in its block), and every stream's slots hold its frames.

use proptest::prelude::*;
use rtcan::layout::{Layout, Span};
use rtcan::schedule::Reject;
use rtcan::{CycleConfig, MessageId, Scheduler};

const CYCLE: CycleConfig = CycleConfig { bit_rate: 1_000_000, cycle_us: 5_000, slots: 30 };

#[derive(Clone, Debug)]
enum Op {
    /// Stream index, period (cycles), frames, reservation µs.
    Admit(u16, u32, u8, u16),
    /// Stream index.
    Leave(u16),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => (0u16..24, prop_oneof![Just(1u32), Just(2), Just(4)], 1u8..=2, 60u16..=163)
            .prop_map(|(s, p, f, us)| Op::Admit(s, p, f, us)),
        1 => (0u16..24).prop_map(Op::Leave),
    ]
}

proptest! {
    #[test]
    fn reservations_never_overlap_move_or_shrink_below_their_frames(
        blocks in 1u8..=4,
        reservable in 600u32..=3_000,
        ops in prop::collection::vec(op(), 1..80),
    ) {
        let mut layout = Layout::new(CYCLE, blocks, reservable).unwrap();
        let mut calendar: Scheduler<48> = Scheduler::new(15, 30);
        let mut need = [0u16; 24];
        for op in ops {
            let before: Vec<(u8, Span)> = layout.iter().collect();
            match op {
                Op::Admit(s, period, frames, us) => {
                    let stream = MessageId(0x100 + s);
                    match layout.admit(&mut calendar, stream, period, frames, us) {
                        Ok(_) if need[usize::from(s)] == 0 => need[usize::from(s)] = us,
                        Ok(got) => {
                            // Registered again: only if its slots hold the frames.
                            let slot = got.slots.trailing_zeros() as u8;
                            prop_assert!(layout.span(slot).is_some_and(|x| x.len_us >= us));
                        }
                        Err(Reject::Full | Reject::NoFreePhase | Reject::Conflict) => {
                            // Refused: nothing placed for it.
                            if need[usize::from(s)] == 0 {
                                prop_assert!(calendar.get(stream).is_none());
                            }
                        }
                        Err(e) => prop_assert!(false, "{e:?}"),
                    }
                }
                Op::Leave(s) => {
                    calendar.remove(MessageId(0x100 + s));
                    layout.release_unused(&calendar);
                    need[usize::from(s)] = 0;
                }
            }
            let placed: Vec<(u8, Span)> = layout.iter().collect();
            // The bitmask the nodes' slot path reads says the same.
            let bits = placed.iter().fold(0u64, |m, &(s, _)| m | 1 << s);
            prop_assert_eq!(layout.placed(), bits);
            // No overlap; inside the cycle, within its block's share (block 0: the sync besides).
            let block_us = CYCLE.cycle_us / u32::from(blocks);
            let sync_end = layout.span(0).unwrap().end_us();
            for (i, &(a, x)) in placed.iter().enumerate() {
                for &(b, y) in &placed[i + 1..] {
                    prop_assert!(!x.overlaps(y), "slots {a} {x:?} and {b} {y:?}");
                }
                if a != 0 {
                    let b0 = u32::from(x.start_us) / block_us * block_us;
                    let share = reservable / u32::from(blocks) + if b0 == 0 { sync_end } else { 0 };
                    prop_assert!(x.end_us() <= b0 + share, "slot {a} {x:?} past its block's share");
                }
            }
            // A slot still in use did not move; every stream's slots hold its frames; a slot
            // no stream uses is free.
            for &(slot, span) in &before {
                if calendar.iter().any(|r| r.phase.slot == slot) {
                    let now = layout.span(slot).unwrap();
                    prop_assert_eq!(now.start_us, span.start_us, "slot {} moved", slot);
                    prop_assert!(now.len_us >= span.len_us, "slot {slot} shrank");
                    // It grew only with no reservation after it in its block then.
                    if now.len_us > span.len_us {
                        let after = before.iter().any(|&(s, x)| s != slot && x.start_us > span.start_us
                            && u32::from(x.start_us) < now.end_us());
                        prop_assert!(!after, "slot {slot} grew over another");
                    }
                }
            }
            for r in calendar.iter() {
                let span = layout.span(r.phase.slot);
                let needs = need[usize::from(r.stream.0 - 0x100)];
                prop_assert!(span.is_some_and(|s| s.len_us >= needs), "{r:?} in {span:?}");
            }
            for &(slot, _) in placed.iter().filter(|&&(s, _)| s != 0) {
                prop_assert!(calendar.iter().any(|r| r.phase.slot == slot), "slot {slot} idle");
            }
        }
    }
}
