//! Which acceptance-filter bank holds which of RTCAN's filters, and which receive FIFO it
//! feeds.

use rtcan::controller::Filter;

/// Filter banks RTCAN uses: all of the F103's, and CAN1's share on the F407 (split at 14).
pub const FILTER_BANKS: usize = 14;

/// Identifier bits of an extended (29-bit) frame.
const EXTENDED_ID_BITS: u32 = 0x1FFF_FFFF;

/// The receive FIFO a bank feeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RxFifo {
    /// FIFO 0 (its own interrupt).
    Fifo0,
    /// FIFO 1 (its own interrupt).
    Fifo1,
}

/// One bank of the plan: its index, FIFO and 32-bit mask filter on the extended identifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bank {
    /// Bank index (0…[`FILTER_BANKS`]).
    pub index: u8,
    /// The FIFO it feeds.
    pub fifo: RxFifo,
    /// Value and mask, within 29 bits.
    pub filter: Filter,
}

/// The banks for `filters`: filter i in bank i, the FIFOs alternating so that a burst fills
/// both hardware FIFOs (six frames, not three) before the interrupt must run. More filters
/// than banks: one bank that accepts everything (RTCAN filters again in software) rather than
/// lose traffic.
pub fn bank_plan(filters: &[Filter]) -> impl Iterator<Item = Bank> + '_ {
    let widened = filters.len() > FILTER_BANKS;
    let plan: &[Filter] = if widened { &[Filter::ACCEPT_ALL] } else { filters };
    plan.iter().enumerate().map(|(i, f)| Bank {
        index: i as u8,
        fifo: if i % 2 == 0 { RxFifo::Fifo0 } else { RxFifo::Fifo1 },
        filter: Filter { value: f.value & EXTENDED_ID_BITS, mask: f.mask & EXTENDED_ID_BITS },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_filter_gets_a_bank_and_the_fifos_alternate() {
        let filters: [Filter; 3] = core::array::from_fn(|i| Filter { value: i as u32, mask: 0xFF });
        let plan: [Option<Bank>; 4] = {
            let mut it = bank_plan(&filters);
            core::array::from_fn(|_| it.next())
        };
        assert_eq!(
            plan,
            [
                Some(Bank { index: 0, fifo: RxFifo::Fifo0, filter: filters[0] }),
                Some(Bank { index: 1, fifo: RxFifo::Fifo1, filter: filters[1] }),
                Some(Bank { index: 2, fifo: RxFifo::Fifo0, filter: filters[2] }),
                None,
            ]
        );
        assert_eq!(bank_plan(&[]).count(), 0, "no filter: nothing passes");
    }

    #[test]
    fn more_filters_than_banks_widen_to_one_that_accepts_everything() {
        let filters = [Filter { value: 1, mask: u32::MAX }; FILTER_BANKS + 1];
        let mut plan = bank_plan(&filters);
        assert_eq!(
            plan.next(),
            Some(Bank { index: 0, fifo: RxFifo::Fifo0, filter: Filter::ACCEPT_ALL })
        );
        assert_eq!(plan.next(), None);
        assert_eq!(bank_plan(&filters[..FILTER_BANKS]).count(), FILTER_BANKS, "exactly full fits");
    }

    #[test]
    fn values_and_masks_keep_the_29_identifier_bits() {
        let f = Filter { value: 0xFFFF_FFFF, mask: 0xE000_0001 };
        let bank = bank_plan(core::slice::from_ref(&f)).next().unwrap();
        assert_eq!(bank.filter, Filter { value: 0x1FFF_FFFF, mask: 0x1 });
    }
}
