//! What the transmit interrupt loads by itself: the frames the node staged
//! ([`rtcan::CanController::stage`], issue 22's staged reloads). The node could not load them
//! because frames of its own were still in the controller; its next call would come ~27 µs
//! after they leave, past CAN's 3-bit intermission, and lose the arbitration that follows
//! (docs/rtcan.md, "Where the fast reaction gains"). The interrupt loads them inside it.
//!
//! The rule, decided here on `CAN_TSR` as plain values (tested on the host; the driver's
//! `TransmitWake` runs it with the registers, with `staged-reloads`):
//! - only once every mailbox is empty, and only if the node's newest frame, the last to leave
//!   (bxCAN sends in load order, `TXFP`), was sent: after one that lost a one-shot arbitration
//!   or was withdrawn, another node's frame is on the wire and the node decides afresh;
//! - only into mailboxes whose results were taken (`RQCP` clear): writing `TXRQ` clears
//!   `TXOK`/`ALST`/`TERR` (RM0008 §24.9.2), and the node would lose that frame's fate;
//! - each frame in the order staged, while it [may still go](StagedFrame::may_load);
//! - once per staging: what is left is dropped, and the driver books what went in for the
//!   node (`Mailboxes::load`) before it looks at the mailboxes again.
//!
//! The bus task (TIM2, above the interrupt) may preempt the interrupt ([`load_staged`]): each
//! of its steps is a short critical section of its own — the decision, a frame's copy, a
//! frame's four mailbox registers and its booking — and the rest (the clock, the free mailbox,
//! the registers' values) runs between them, so it holds a reservation's frame back by one
//! mailbox's writes at most, as the receive interrupt holds it back by one frame's push. Every
//! call of the node on frame-sized reservations takes the loads first and stops an interrupt
//! under way ([`StagedLoads::take_loaded`] with `node_call`): an interrupt it preempted loads
//! nothing after, so the node never misses a frame the interrupt loaded. The driver's other
//! looks at the mailboxes take the loads without ending the staging: the gateway's bus tap
//! looks after the node's call, before the interrupt may run.

use core::cell::RefCell;

use critical_section::Mutex;
use rtcan::controller::StagedFrame;
use rtcan::{Frame, FrameId, Micros};

use crate::mailboxes::{MailboxStatus, MAILBOXES};

/// The staged frames between the bus task and the transmit interrupt.
#[derive(Debug, Default)]
pub struct StagedLoads {
    frames: [Option<StagedFrame>; MAILBOXES],
    /// The mailbox of the node's newest frame in the controller when they were staged.
    newest: Option<usize>,
    /// Which staging this is: a new one, or the bus task taking the loads, ends the last.
    generation: u32,
    /// What the interrupt loaded, not yet booked by the driver: (mailbox, identifier).
    loaded: [Option<(usize, FrameId)>; MAILBOXES],
    /// The interrupt is loading (between its decision and its end).
    under_way: bool,
}

impl StagedLoads {
    /// Nothing staged.
    pub const fn new() -> Self {
        Self {
            frames: [None; MAILBOXES],
            newest: None,
            generation: 0,
            loaded: [None; MAILBOXES],
            under_way: false,
        }
    }

    /// Replaces the staged frames with `frames` (the first [`MAILBOXES`]); `newest` is the
    /// mailbox of the node's newest frame still in the controller.
    pub fn stage(&mut self, frames: &[StagedFrame], newest: Option<usize>) {
        self.frames = core::array::from_fn(|i| frames.get(i).copied());
        self.newest = newest;
        self.generation = self.generation.wrapping_add(1);
    }

    /// True if frames wait for the interrupt.
    pub fn any(&self) -> bool {
        self.frames[0].is_some()
    }

    /// Takes what the interrupt loaded since the last call, in load order (the driver books
    /// them before it reads the mailboxes). With `node_call` (the node's call begins:
    /// `CanController::staged_loaded`) an interrupt it preempted loads nothing more (the
    /// staging ends); a staging no interrupt has started on stands either way: the node keeps
    /// or drops it itself (`SlotTx`).
    pub fn take_loaded(&mut self, node_call: bool) -> impl Iterator<Item = (usize, FrameId)> {
        if node_call {
            self.stop_interrupt();
        }
        core::mem::take(&mut self.loaded).into_iter().map_while(|l| l)
    }

    /// Ends the staging if an interrupt is loading it.
    fn stop_interrupt(&mut self) {
        if self.under_way {
            self.frames = [None; MAILBOXES];
            self.generation = self.generation.wrapping_add(1);
            self.under_way = false;
        }
    }

    /// The staging to load, if the module's rule allows it on `CAN_TSR` (`status`,
    /// `results_waiting`: `RQCP`).
    fn start(
        &self,
        status: &[MailboxStatus; MAILBOXES],
        results_waiting: &[bool; MAILBOXES],
    ) -> Option<u32> {
        let empty = status.iter().all(|s| s.empty);
        let sent = self.newest.is_some_and(|i| status[i].txok && results_waiting[i]);
        (self.any() && empty && sent).then_some(self.generation)
    }

    /// Staged frame `k` of staging `generation`, if that staging still stands.
    fn frame(&self, generation: u32, k: usize) -> Option<StagedFrame> {
        (generation == self.generation).then(|| self.frames[k]).flatten()
    }

    /// If staging `generation` still stands: `write`s its frame (`id`) into `mailbox` and
    /// books it.
    fn commit(
        &mut self,
        generation: u32,
        (mailbox, id): (usize, FrameId),
        write: impl FnOnce(),
    ) -> bool {
        if generation != self.generation {
            return false;
        }
        write();
        if let Some(free) = self.loaded.iter_mut().find(|l| l.is_none()) {
            *free = Some((mailbox, id));
        }
        true
    }

    /// The staged frames of staging `generation` are gone, loaded or not.
    fn finish(&mut self, generation: u32) {
        if generation == self.generation {
            self.frames = [None; MAILBOXES];
            self.under_way = false;
        }
    }
}

/// The transmit interrupt's loads (module documentation), with `CAN_TSR` read as `status` and
/// `results_waiting` (`RQCP`): each frame's mailbox registers made by `compose` outside the
/// critical sections, written by `write(mailbox, registers)` inside one. Returns how many it
/// loaded.
pub fn load_staged<R>(
    staged: &Mutex<RefCell<StagedLoads>>,
    status: &[MailboxStatus; MAILBOXES],
    results_waiting: &[bool; MAILBOXES],
    now: impl FnOnce() -> Micros,
    mut compose: impl FnMut(&Frame) -> R,
    write: impl Fn(usize, &R),
) -> usize {
    let start = critical_section::with(|cs| {
        let mut s = staged.borrow_ref_mut(cs);
        let generation = s.start(status, results_waiting);
        match generation {
            Some(_) => s.under_way = true,
            None => s.frames = [None; MAILBOXES], // once per staging
        }
        generation
    });
    let Some(generation) = start else { return 0 };
    let now = now();
    let mut used = [false; MAILBOXES];
    let mut n = 0;
    for k in 0..MAILBOXES {
        let Some(s) = critical_section::with(|cs| staged.borrow_ref(cs).frame(generation, k))
        else {
            break;
        };
        let free = (0..MAILBOXES).find(|&i| !results_waiting[i] && !used[i]);
        let (Some(i), true) = (free, s.may_load(now)) else { break };
        let registers = compose(&s.frame);
        let committed = critical_section::with(|cs| {
            let write = || write(i, &registers);
            staged.borrow_ref_mut(cs).commit(generation, (i, s.frame.id()), write)
        });
        if !committed {
            break;
        }
        used[i] = true;
        n += 1;
    }
    critical_section::with(|cs| staged.borrow_ref_mut(cs).finish(generation));
    n
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::cell::RefCell as StdRefCell;
    use std::vec::Vec;

    use super::*;

    const EMPTY: MailboxStatus =
        MailboxStatus { empty: true, txok: false, alst: false, terr: false };
    const SENT: MailboxStatus = MailboxStatus { txok: true, ..EMPTY };
    const BUSY: MailboxStatus = MailboxStatus { empty: false, ..EMPTY };

    fn staged(latest: Micros) -> [StagedFrame; 3] {
        core::array::from_fn(|i| StagedFrame {
            frame: Frame::from_raw(0x100 + i as u32, &[i as u8]).unwrap(),
            latest,
        })
    }

    fn shared(frames: &[StagedFrame], newest: Option<usize>) -> Mutex<RefCell<StagedLoads>> {
        let s = Mutex::new(RefCell::new(StagedLoads::new()));
        critical_section::with(|cs| s.borrow_ref_mut(cs).stage(frames, newest));
        s
    }

    fn any(s: &Mutex<RefCell<StagedLoads>>) -> bool {
        critical_section::with(|cs| s.borrow_ref(cs).any())
    }

    /// What the node's call takes first (`staged_loaded`): the loads, and an interrupt under
    /// way stops.
    fn booked(s: &Mutex<RefCell<StagedLoads>>) -> Vec<(usize, FrameId)> {
        critical_section::with(|cs| s.borrow_ref_mut(cs).take_loaded(true).collect())
    }

    /// The interrupt at `now`: the mailboxes written, in order.
    fn interrupt(
        s: &Mutex<RefCell<StagedLoads>>,
        status: [MailboxStatus; 3],
        waiting: [bool; 3],
        now: Micros,
    ) -> Vec<(usize, Frame)> {
        let written = StdRefCell::new(Vec::new());
        let n = load_staged(
            s,
            &status,
            &waiting,
            || now,
            |f| *f,
            |i, f| written.borrow_mut().push((i, *f)),
        );
        let written = written.into_inner();
        assert_eq!(n, written.len());
        written
    }

    #[test]
    fn staged_frames_go_in_order_into_the_mailboxes_whose_results_were_taken() {
        let frames = staged(500);
        let s = shared(&frames, Some(1));
        assert!(any(&s));
        // Mailbox 1's frame just went out (its result waits): the other two take two frames.
        let written = interrupt(&s, [EMPTY, SENT, EMPTY], [false, true, false], 100);
        assert_eq!(written, [(0, frames[0].frame), (2, frames[1].frame)]);
        assert!(!any(&s), "the third is dropped: once per staging");
        assert_eq!(booked(&s), [(0, frames[0].frame.id()), (2, frames[1].frame.id())]);
        assert_eq!(booked(&s), [], "booked once");
        assert_eq!(interrupt(&s, [EMPTY, SENT, EMPTY], [false, true, false], 100), []);
    }

    #[test]
    fn nothing_loads_unless_the_controller_is_empty_after_the_newest_frame_was_sent() {
        let frames = staged(500);
        let cases = [
            // A frame still in a mailbox.
            ([SENT, BUSY, EMPTY], [true, false, false], Some(0)),
            // The newest frame lost its arbitration or was withdrawn (no TXOK).
            ([EMPTY, SENT, EMPTY], [true, true, false], Some(0)),
            // Its result was taken already: the node looked since, and decided.
            ([SENT, EMPTY, EMPTY], [false, false, false], Some(0)),
            // Staged with no frame of the node's in the controller.
            ([SENT, EMPTY, EMPTY], [true, false, false], None),
        ];
        for (status, waiting, newest) in cases {
            let s = shared(&frames, newest);
            assert_eq!(interrupt(&s, status, waiting, 100), [], "{status:?}");
            assert!(!any(&s), "{status:?}: dropped");
            assert_eq!(booked(&s), []);
        }
        let s = shared(&frames, Some(0));
        let written = interrupt(&s, [SENT, EMPTY, EMPTY], [true, false, false], 100);
        assert_eq!(written.iter().map(|w| w.0).collect::<Vec<_>>(), [1, 2]);
    }

    #[test]
    fn a_frame_past_its_latest_start_stops_the_loading() {
        let mut frames = staged(500);
        frames[1].latest = 100;
        let s = shared(&frames, Some(2));
        let written = interrupt(&s, [EMPTY, EMPTY, SENT], [false, false, true], 100);
        assert_eq!(written, [(0, frames[0].frame)]);
        assert!(!any(&s));
        let s = shared(&frames, Some(2));
        assert_eq!(interrupt(&s, [EMPTY, EMPTY, SENT], [false, false, true], 500), []);
    }

    #[test]
    fn a_new_staging_replaces_the_last() {
        let s = shared(&staged(500), Some(0));
        let one = [StagedFrame { frame: Frame::from_raw(0x200, &[]).unwrap(), latest: 500 }];
        critical_section::with(|cs| s.borrow_ref_mut(cs).stage(&one, Some(0)));
        let written = interrupt(&s, [SENT, EMPTY, EMPTY], [true, false, false], 100);
        assert_eq!(written, [(1, one[0].frame)]);
        critical_section::with(|cs| s.borrow_ref_mut(cs).stage(&[], Some(0)));
        assert!(!any(&s));
    }

    #[test]
    fn the_driver_books_the_loads_without_ending_the_staging() {
        // The gateway's bus tap takes the controller's results after the node's call, which
        // staged: the staging stands for the interrupt that follows.
        let frames = staged(500);
        let s = shared(&frames, Some(0));
        assert_eq!(critical_section::with(|cs| s.borrow_ref_mut(cs).take_loaded(false).count()), 0);
        assert!(any(&s));
        let written = interrupt(&s, [SENT, EMPTY, EMPTY], [true, false, false], 100);
        assert_eq!(written.len(), 2);
        assert_eq!(booked(&s).len(), 2);
    }

    #[test]
    fn a_staging_no_interrupt_started_on_stands_when_the_node_looks() {
        // The node's call at a loaded frame's guard keeps its staging (`SlotTx`): so does the
        // controller, for the interrupt when the frame on the wire ends.
        let s = shared(&staged(500), Some(0));
        assert_eq!(booked(&s), []);
        assert!(any(&s));
        assert_eq!(interrupt(&s, [SENT, EMPTY, EMPTY], [true, false, false], 100).len(), 2);
    }

    #[test]
    fn an_interrupt_the_bus_task_preempted_loads_nothing_after_it_took_the_loads() {
        let frames = staged(500);
        for restage in [false, true] {
            let s = shared(&frames, Some(0));
            let written = StdRefCell::new(Vec::new());
            let mut composed = 0;
            // The bus task preempts the interrupt while it makes the second frame's registers:
            // it books the first frame, and may stage anew.
            let compose = |f: &Frame| {
                composed += 1;
                if composed == 2 {
                    assert_eq!(booked(&s), [(1, frames[0].frame.id())]);
                    if restage {
                        critical_section::with(|cs| s.borrow_ref_mut(cs).stage(&frames, Some(1)));
                    }
                }
                *f
            };
            let write = |i, f: &Frame| written.borrow_mut().push((i, *f));
            let status = [SENT, EMPTY, EMPTY];
            let n = load_staged(&s, &status, &[true, false, false], || 100, compose, write);
            assert_eq!((n, written.into_inner()), (1, std::vec![(1, frames[0].frame)]));
            assert_eq!(any(&s), restage, "a new staging stands");
            assert_eq!(booked(&s), []);
            assert_eq!(any(&s), restage, "and still stands at the node's next look");
        }
    }
}
