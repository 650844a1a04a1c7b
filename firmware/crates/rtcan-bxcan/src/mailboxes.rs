//! The transmit mailboxes' bookkeeping: which frame each holds, in which order they were
//! loaded, and what `CAN_TSR` says became of them (RM0008 §24.9.2).

use rtcan::controller::TxOutcome;
use rtcan::FrameId;

/// Transmit mailboxes of a bxCAN.
pub const MAILBOXES: usize = 3;

/// What `CAN_TSR` says of one transmit mailbox.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MailboxStatus {
    /// `TME`: the mailbox is empty (its frame finished, or it never held one).
    pub empty: bool,
    /// `TXOK`: its last frame went out.
    pub txok: bool,
    /// `ALST`: its last frame lost arbitration.
    pub alst: bool,
    /// `TERR`: its last frame ended in an error.
    pub terr: bool,
}

impl MailboxStatus {
    /// What became of the frame of an emptied mailbox: sent, lost arbitration, error, or —
    /// none of the three — aborted before it went out.
    pub const fn outcome(&self) -> TxOutcome {
        if self.txok {
            TxOutcome::Sent
        } else if self.alst {
            TxOutcome::LostArbitration
        } else if self.terr {
            TxOutcome::Error
        } else {
            TxOutcome::Aborted
        }
    }
}

/// The frames in the mailboxes until their results are collected, with their load order.
#[derive(Debug, Default)]
pub struct Mailboxes {
    loaded: [Option<(FrameId, u32)>; MAILBOXES],
    next_seq: u32,
}

/// Mailboxes whose frames finished, oldest load first: (mailbox, identifier).
pub type Finished = ([(usize, FrameId); MAILBOXES], usize);

impl Mailboxes {
    /// Nothing loaded.
    pub const fn new() -> Self {
        Self { loaded: [None; MAILBOXES], next_seq: 0 }
    }

    /// A mailbox to load: empty, and its previous frame's result collected (loading one whose
    /// result was not collected would clear it: `RQCP` clears when `TXRQ` is set).
    pub fn free(&self, status: &[MailboxStatus; MAILBOXES]) -> Option<usize> {
        (0..MAILBOXES).find(|&i| status[i].empty && self.loaded[i].is_none())
    }

    /// Mailbox `i` now holds the frame `id`, loaded after every frame still held.
    pub fn load(&mut self, i: usize, id: FrameId) {
        self.loaded[i] = Some((id, self.next_seq));
        self.next_seq = self.next_seq.wrapping_add(1);
    }

    /// The mailbox of the newest frame loaded and not yet collected: the last of them to
    /// leave, as they go in load order (`TXFP`).
    pub fn newest(&self) -> Option<usize> {
        let age = |i: usize| self.loaded[i].map(|(_, seq)| self.next_seq.wrapping_sub(seq));
        (0..MAILBOXES).filter(|&i| self.loaded[i].is_some()).min_by_key(|&i| age(i))
    }

    /// The mailboxes holding a frame that has not finished (what an abort asks for).
    pub fn pending(&self, status: &[MailboxStatus; MAILBOXES]) -> [bool; MAILBOXES] {
        core::array::from_fn(|i| self.loaded[i].is_some() && !status[i].empty)
    }

    /// Takes out the mailboxes whose frames finished, oldest load first. The load counter
    /// wraps (after 2³² frames, six days of a busy bus): the order is by age, the distance
    /// back from the next load, which stays right across the wrap.
    pub fn take_finished(&mut self, status: &[MailboxStatus; MAILBOXES]) -> Finished {
        let mut done = [(0u32, 0usize); MAILBOXES];
        let mut n = 0;
        for (i, l) in self.loaded.iter().enumerate() {
            if let (Some((_, seq)), true) = (l, status[i].empty) {
                done[n] = (self.next_seq.wrapping_sub(*seq), i);
                n += 1;
            }
        }
        // Oldest (largest age) first; a network of three, sorted in place without linking a
        // general sort into the image.
        for a in 0..n {
            for b in a + 1..n {
                if done[b].0 > done[a].0 {
                    done.swap(a, b);
                }
            }
        }
        let mut out = [(0, FrameId::from_raw(0).expect("0 is an identifier")); MAILBOXES];
        let mut len = 0;
        for &(_, i) in &done[..n] {
            if let Some((id, _)) = self.loaded[i].take() {
                out[len] = (i, id);
                len += 1;
            }
        }
        (out, len)
    }
}

/// How many of the mailboxes an abort asked for (`asked`) were withdrawn before their frame
/// went out: empty now and not sent.
pub fn withdrawn(asked: &[bool; MAILBOXES], status: &[MailboxStatus; MAILBOXES]) -> usize {
    (0..MAILBOXES).filter(|&i| asked[i] && status[i].empty && !status[i].txok).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(raw: u32) -> FrameId {
        FrameId::from_raw(raw).unwrap()
    }

    const BUSY: MailboxStatus =
        MailboxStatus { empty: false, txok: false, alst: false, terr: false };
    const EMPTY: MailboxStatus =
        MailboxStatus { empty: true, txok: false, alst: false, terr: false };
    const SENT: MailboxStatus = MailboxStatus { txok: true, ..EMPTY };

    #[test]
    fn the_status_bits_decode_in_the_reference_manuals_precedence() {
        assert_eq!(SENT.outcome(), TxOutcome::Sent);
        // TXOK wins over the others (a frame that lost once, then went out).
        assert_eq!(MailboxStatus { alst: true, terr: true, ..SENT }.outcome(), TxOutcome::Sent);
        let lost = MailboxStatus { alst: true, terr: true, ..EMPTY };
        assert_eq!(lost.outcome(), TxOutcome::LostArbitration);
        assert_eq!(MailboxStatus { terr: true, ..EMPTY }.outcome(), TxOutcome::Error);
        assert_eq!(EMPTY.outcome(), TxOutcome::Aborted);
    }

    #[test]
    fn a_mailbox_is_free_once_empty_and_collected() {
        let mut m = Mailboxes::new();
        assert_eq!(m.free(&[EMPTY; 3]), Some(0));
        m.load(0, id(1));
        assert_eq!(m.free(&[BUSY, EMPTY, EMPTY]), Some(1));
        // Empty again but its result not collected: not free.
        assert_eq!(m.free(&[SENT, BUSY, EMPTY]), Some(2));
        assert_eq!(m.free(&[SENT, BUSY, BUSY]), None);
        assert_eq!(m.pending(&[BUSY, BUSY, BUSY]), [true, false, false]);
        assert_eq!(m.pending(&[SENT, BUSY, BUSY]), [false; 3]);
        let (done, n) = m.take_finished(&[SENT, BUSY, BUSY]);
        assert_eq!(&done[..n], &[(0, id(1))]);
        assert_eq!(m.free(&[SENT, BUSY, BUSY]), Some(0));
        assert_eq!(m.take_finished(&[SENT; 3]).1, 0, "collected once");
    }

    #[test]
    fn finished_frames_come_out_in_load_order_across_the_counters_wrap() {
        for start in [0u32, u32::MAX - 1, u32::MAX, 7] {
            let mut m = Mailboxes { loaded: [None; MAILBOXES], next_seq: start };
            // Loaded into mailboxes 2, 0, 1 in that order (the counter wraps between them for
            // the starts near u32::MAX).
            m.load(2, id(0x20));
            m.load(0, id(0x30));
            m.load(1, id(0x10));
            let (done, n) = m.take_finished(&[SENT; 3]);
            assert_eq!(&done[..n], &[(2, id(0x20)), (0, id(0x30)), (1, id(0x10))], "{start}");
            // Only the emptied ones, still in order.
            m.load(1, id(1));
            m.load(2, id(2));
            m.load(0, id(3));
            let (done, n) = m.take_finished(&[SENT, BUSY, EMPTY]);
            assert_eq!(&done[..n], &[(2, id(2)), (0, id(3))], "{start}");
        }
    }

    #[test]
    fn the_newest_frame_is_the_last_loaded_across_the_counters_wrap() {
        for start in [0u32, u32::MAX, 7] {
            let mut m = Mailboxes { loaded: [None; MAILBOXES], next_seq: start };
            assert_eq!(m.newest(), None);
            m.load(2, id(1));
            m.load(0, id(2));
            assert_eq!(m.newest(), Some(0), "{start}");
            m.load(1, id(3));
            assert_eq!(m.newest(), Some(1), "{start}");
            m.take_finished(&[BUSY, SENT, BUSY]);
            assert_eq!(m.newest(), Some(0), "{start}: the newest still loaded");
        }
    }

    #[test]
    fn an_abort_counts_only_frames_withdrawn_before_they_went_out() {
        let asked = [true, true, false];
        assert_eq!(withdrawn(&asked, &[EMPTY, EMPTY, EMPTY]), 2);
        // Mailbox 0 finished on the wire (sent); mailbox 1 still transmitting.
        assert_eq!(withdrawn(&asked, &[SENT, BUSY, EMPTY]), 0);
        let failed = MailboxStatus { terr: true, ..EMPTY };
        assert_eq!(withdrawn(&asked, &[failed, EMPTY, EMPTY]), 2);
    }
}
