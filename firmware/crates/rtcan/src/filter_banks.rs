//! Acceptance filters for a controller with few filter banks (bxCAN: 14 on the F103).
//!
//! A node wants the frames of a few streams: the syncs, every node's management stream and the
//! streams it subscribed to. Each is a mask filter on the message ID — never one identifier,
//! since a stream's frames differ in laxity and fragment counter, which is also why bxCAN's list
//! mode (exact identifiers, two per bank) does not help RTCAN. When there are more filters than
//! banks, [`fit`] merges filters into wider ones (a merged filter accepts everything either
//! accepted) until they fit, choosing each time the merge that keeps the result narrowest: the
//! hardware then lets some unwanted frames through, and the node's software filter, which
//! always runs, drops them. A wanted frame is never rejected.

use crate::controller::Filter;
use crate::id::{MessageId, FRAGMENT_BITS, MESSAGE_ID_BITS};

/// The identifier bits of the message ID field.
pub const MESSAGE_FIELD: u32 = ((1 << MESSAGE_ID_BITS) - 1) << FRAGMENT_BITS;

/// All 29 identifier bits.
pub const ID_BITS: u32 = (1 << 29) - 1;

impl Filter {
    /// Every frame of stream `message`, whatever its laxity and fragment.
    pub const fn stream(message: MessageId) -> Filter {
        Filter { value: (message.0 as u32) << FRAGMENT_BITS, mask: MESSAGE_FIELD }
    }

    /// Every frame whose message ID has `low` in its low `bits` bits (R2P: `bits` = 8, `low` =
    /// 0 is every node's management stream).
    pub const fn message_low_bits(low: u16, bits: u32) -> Filter {
        let field = ((1u32 << bits) - 1) << FRAGMENT_BITS;
        Filter { value: ((low as u32) << FRAGMENT_BITS) & field, mask: field }
    }

    /// The smallest filter accepting everything `self` or `other` accepts.
    pub const fn merge(self, other: Filter) -> Filter {
        let mask = self.mask & other.mask & !(self.value ^ other.value) & ID_BITS;
        Filter { value: self.value & mask, mask }
    }

    /// True if every identifier `other` accepts, `self` accepts too.
    pub const fn covers(&self, other: &Filter) -> bool {
        let (m, o) = (self.mask & ID_BITS, other.mask & ID_BITS);
        m & !o == 0 && (self.value ^ other.value) & m == 0
    }

    /// Identifier bits this filter leaves free: it accepts 2^free identifiers.
    pub const fn free_bits(&self) -> u32 {
        29 - (self.mask & ID_BITS).count_ones()
    }
}

/// What [`fit`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fit {
    /// Banks used: `out[..used]` are the filters to program.
    pub used: usize,
    /// True if filters were merged into wider ones: the hardware passes frames nobody wanted,
    /// which the software filter drops.
    pub widened: bool,
}

/// Fits the `wanted` filters into `out` (one per bank), merging the closest ones when there are
/// more than banks. With no bank (`out` empty) nothing can be expressed: `used` = 0 and
/// `widened` tells the caller to accept everything instead. Filters that another one covers
/// take no bank.
pub fn fit(wanted: &[Filter], out: &mut [Filter]) -> Fit {
    let mut fit = Fit { used: 0, widened: false };
    for w in wanted {
        fit = fit_one(out, fit, *w);
    }
    fit
}

/// Adds one wanted filter to the banks `out[..so_far.used]` (as [`fit`] does for each): for a
/// node that builds its list on the fly, without a buffer.
pub fn fit_one(out: &mut [Filter], so_far: Fit, w: Filter) -> Fit {
    let Fit { mut used, mut widened } = so_far;
    {
        if w.value & w.mask & !ID_BITS != 0 {
            return so_far; // demands a bit above the 29-bit identifier: accepts no frame
        }
        let w = Filter { value: w.value & w.mask & ID_BITS, mask: w.mask & ID_BITS };
        if out[..used].iter().any(|f| f.covers(&w)) {
            return so_far;
        }
        // Filters the new one covers are dropped: it replaces them.
        let mut k = 0;
        for i in 0..used {
            if !w.covers(&out[i]) {
                out[k] = out[i];
                k += 1;
            }
        }
        used = k;
        if used < out.len() {
            out[used] = w;
            return Fit { used: used + 1, widened };
        }
        if out.is_empty() {
            return Fit { used: 0, widened: true };
        }
        // Full: merge the pair (among the banks and the new filter) whose merge is narrowest.
        widened = true;
        let n = used;
        let at = |i: usize| if i == n { w } else { out[i] };
        let (mut best, mut best_free) = ((0, n), u32::MAX);
        for i in 0..=n {
            for j in i + 1..=n {
                let free = at(i).merge(at(j)).free_bits();
                if free < best_free {
                    (best, best_free) = ((i, j), free);
                }
            }
        }
        let merged = at(best.0).merge(at(best.1));
        // best.0 < n: it is a bank; best.1 is a bank or the new filter.
        out[best.0] = merged;
        if best.1 < n {
            out[best.1] = w;
        }
        // The merged filter may now cover others: drop them.
        let mut k = 0;
        for i in 0..used {
            if i == best.0 || !merged.covers(&out[i]) {
                out[k] = out[i];
                k += 1;
            }
        }
        used = k;
    }
    Fit { used, widened }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;
    use crate::id::FrameId;
    use crate::laxity::Laxity;

    fn id(laxity: u8, message: u16, fragment: u8) -> u32 {
        FrameId { laxity: Laxity::from_code(laxity), message: MessageId(message), fragment }
            .to_raw()
    }

    const SYNCS: Filter = Filter { value: 0, mask: ID_BITS & !(0xFF << 7) };

    r2p_testkit::suite! {
        fn a_stream_filter_passes_its_frames_and_no_other_streams() {
            let f = Filter::stream(MessageId(0x4203));
            assert!(f.accepts(id(0, 0x4203, 0)) && f.accepts(id(63, 0x4203, 127)));
            assert!(!f.accepts(id(9, 0x4202, 3)) && !f.accepts(id(9, 0x4303, 3)));
            let mgmt = Filter::message_low_bits(0, 8);
            assert!(mgmt.accepts(id(63, 0x4200, 5)) && !mgmt.accepts(id(63, 0x4201, 5)));
            assert!(SYNCS.accepts(id(0, 0x45, 0)) && !SYNCS.accepts(id(0, 0x145, 0)));
            assert!(!SYNCS.accepts(id(1, 0x45, 0)) && !SYNCS.accepts(id(0, 0x45, 1)));
        }

        fn few_filters_are_programmed_as_they_are() {
            let wanted = [SYNCS, Filter::message_low_bits(0, 8), Filter::stream(MessageId(0x4203))];
            let mut out = [Filter::ACCEPT_ALL; 14];
            assert_eq!(fit(&wanted, &mut out), Fit { used: 3, widened: false });
            assert_eq!(out[..3], wanted);
            // A filter covered by another takes no bank, in either order.
            let wanted = [Filter::stream(MessageId(0x4300)), Filter::message_low_bits(0, 8)];
            assert_eq!(fit(&wanted, &mut out), Fit { used: 1, widened: false });
            assert_eq!(out[0], Filter::message_low_bits(0, 8));
        }

        fn too_many_streams_merge_the_closest_and_never_reject_a_wanted_frame() {
            // 16 streams of node 0x42 and 0x43 into 4 banks: neighbours merge first.
            let mut wanted = [Filter::ACCEPT_ALL; 16];
            for (k, w) in wanted.iter_mut().enumerate() {
                *w = Filter::stream(MessageId(0x4201 + (k as u16 % 8) + 0x100 * (k as u16 / 8)));
            }
            let mut out = [Filter::ACCEPT_ALL; 4];
            let fit = fit(&wanted, &mut out);
            assert!(fit.widened && fit.used <= 4);
            for w in &wanted {
                let m = (w.value >> 7) as u16;
                assert!(out[..fit.used].iter().any(|f| f.accepts(id(9, m, 1))), "{m:04x}");
            }
            // Still narrower than everything: another node's streams stay out.
            assert!(!out[..fit.used].iter().any(|f| f.accepts(id(9, 0x9901, 1))));
        }

        fn no_bank_means_accept_everything() {
            let mut out: [Filter; 0] = [];
            assert_eq!(fit(&[SYNCS], &mut out), Fit { used: 0, widened: true });
            assert_eq!(fit(&[], &mut out), Fit { used: 0, widened: false });
        }
    }
}

#[cfg(test)]
mod proptests {
    extern crate std;

    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    fn filter() -> impl Strategy<Value = Filter> {
        prop_oneof![
            any::<u16>().prop_map(|m| Filter::stream(MessageId(m))),
            (any::<u32>(), any::<u32>()).prop_map(|(v, m)| Filter { value: v, mask: m }),
            (any::<u16>(), 1u32..16).prop_map(|(v, b)| Filter::message_low_bits(v, b)),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        /// Whatever the filters and banks, a frame some wanted filter accepts passes the banks;
        /// when nothing was merged, the banks accept exactly what the wanted filters accept.
        #[test]
        fn no_wanted_frame_is_ever_rejected(
            wanted in prop::collection::vec(filter(), 0..40),
            banks in 1usize..=14,
            probes in prop::collection::vec(any::<u32>(), 0..64),
        ) {
            let mut out = [Filter::ACCEPT_ALL; 14];
            let fit = fit(&wanted, &mut out[..banks]);
            prop_assert!(fit.used <= banks);
            let programmed = &out[..fit.used];
            let hw = |raw: u32| programmed.iter().any(|f| f.accepts(raw));
            let sw = |raw: u32| wanted.iter().any(|f| f.accepts(raw));
            // Probe the wanted filters' own identifiers, their neighbours and random ones.
            let mut ids: Vec<u32> = probes.iter().map(|p| p & ID_BITS).collect();
            for w in &wanted {
                ids.push(w.value & w.mask & ID_BITS);
                ids.push((w.value & w.mask | !w.mask) & ID_BITS);
                ids.push(((w.value & w.mask) ^ 0x80) & ID_BITS);
            }
            for &raw in &ids {
                prop_assert!(!sw(raw) || hw(raw), "{raw:08x} wanted but rejected");
                if !fit.widened {
                    prop_assert_eq!(hw(raw), sw(raw), "{:08x}", raw);
                }
            }
            if wanted.len() <= banks {
                prop_assert!(!fit.widened);
            }
        }
    }
}
