//! A signed image moved into a DFU slot over a simulated link that loses, duplicates and delays
//! messages, is cut off for a while (a bus partition), and whose receiver reboots mid-transfer:
//! the slot ends with the image, verified, every time.

use r2p_boot::layout::STM32F103CB as MAP;
use r2p_boot::sender::{Phase, Sender};
use r2p_boot::sign::{public_key, sign, Meta};
use r2p_boot::transfer::{Msg, Receiver, State, Status, BLOCK_MAX};
use r2p_boot::{verify_slot, Expect, Refusal, Version, TRAILER_LEN};
use r2p_module::RamFlash;

const SEED: [u8; 32] = [0x33; 32];
type Dfu = RamFlash<{ 55 * 1024 }, 1024>;

fn signed(len: usize) -> Vec<u8> {
    let image: Vec<u8> =
        (0..len).map(|i| (i as u32).wrapping_mul(2_654_435_761).to_le_bytes()[3]).collect();
    let meta =
        Meta { version: Version { major: 2, minor: 0, patch: 0 }, kind: "psu", mcu: "STM32F103CB" };
    sign(&image, &meta, &SEED).unwrap()
}

fn verify(dfu: &mut Dfu) -> Result<(), Refusal> {
    let key = public_key(&SEED);
    let expect = Expect { mcu: "STM32F103CB", kind: Some("psu"), public_key: &key };
    verify_slot(dfu, 0, MAP.active.size, &expect).map(|_| ())
}

/// A small deterministic generator (xorshift) for the link's faults.
struct Rng(u64);
impl Rng {
    fn chance(&mut self, percent: u64) -> bool {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % 100 < percent
    }
}

struct Faults {
    loss: u64,
    duplicate: u64,
    /// Milliseconds during which nothing passes.
    partition: std::ops::Range<u64>,
    /// When the receiver reboots (forgets its transfer).
    reboot_at: Option<u64>,
}

/// Runs a transfer at 1 ms steps (each message takes 1–3 ms each way); returns the sender's
/// outcome, the steps taken and the messages sent.
fn run(image: &[u8], faults: Faults, seed: u64) -> (Phase, Sender<'_>, u64, u32, Dfu) {
    let mut dfu = Dfu::new();
    let mut rx = Receiver::new(MAP.active.size);
    let mut tx = Sender::new(image, 7, 16, 50);
    let mut rng = Rng(seed);
    let mut to_rx: Vec<(u64, Vec<u8>)> = Vec::new();
    let mut to_tx: Vec<(u64, Status)> = Vec::new();
    let mut sent = 0;
    let mut now = 0;
    while now < 600_000 && !matches!(tx.phase(), Phase::Done | Phase::Refused(_)) {
        let cut = faults.partition.contains(&now);
        if faults.reboot_at == Some(now) {
            rx = Receiver::new(MAP.active.size);
        }
        while let Some(m) = tx.poll(now) {
            let mut buf = [0; 64];
            let n = m.encode(&mut buf);
            sent += 1;
            if cut || rng.chance(faults.loss) {
                continue;
            }
            // CAN delivers one sender's frames in order: a message arrives 1–3 ms after it is
            // sent, never before the one sent before it.
            let copies = if rng.chance(faults.duplicate) { 2 } else { 1 };
            for _ in 0..copies {
                let at = (now + 1 + rng.0 % 3).max(to_rx.last().map_or(0, |(t, _)| *t));
                to_rx.push((at, buf[..n].to_vec()));
            }
        }
        let (due, later): (Vec<_>, Vec<_>) = to_rx.drain(..).partition(|(t, _)| *t <= now);
        to_rx = later;
        for (_, bytes) in due {
            let msg = Msg::decode(&bytes)
                .expect("the link does not corrupt (CAN's CRC drops corrupt frames)");
            let s = rx.handle(&msg, &mut dfu, verify);
            if !cut && !rng.chance(faults.loss) {
                let at = (now + 1 + rng.0 % 3).max(to_tx.last().map_or(0, |(t, _)| *t));
                to_tx.push((at, s));
            }
        }
        let (due, later): (Vec<_>, Vec<_>) = to_tx.drain(..).partition(|(t, _)| *t <= now);
        to_tx = later;
        for (_, s) in due {
            tx.on_status(&s, now);
        }
        now += 1;
    }
    (tx.phase(), tx, now, sent, dfu)
}

#[test]
fn a_clean_link_moves_the_image_in_one_pass() {
    let image = signed(20_000);
    let (phase, tx, ms, sent, mut dfu) =
        run(&image, Faults { loss: 0, duplicate: 0, partition: 0..0, reboot_at: None }, 1);
    assert_eq!(phase, Phase::Done);
    assert_eq!(verify(&mut dfu), Ok(()));
    let blocks = image.len().div_ceil(BLOCK_MAX) as u32;
    assert_eq!(sent, blocks + 2, "begin, each block once, end");
    assert_eq!((tx.timeouts, tx.restarts), (0, 0));
    println!("clean: {} B in {sent} messages, {ms} ms of simulated link", image.len());
}

#[test]
fn loss_duplicates_a_partition_and_a_reboot_cost_time_not_bytes() {
    let image = signed(52_000);
    for seed in 1..=8 {
        let faults = Faults {
            loss: 10,
            duplicate: 5,
            partition: 700..2_200,
            reboot_at: Some(200 + seed * 50),
        };
        let (phase, tx, ms, sent, mut dfu) = run(&image, faults, seed);
        assert_eq!(phase, Phase::Done, "seed {seed}");
        assert_eq!(verify(&mut dfu), Ok(()), "seed {seed}");
        assert_eq!(&dfu.bytes()[..image.len() - TRAILER_LEN], &image[..image.len() - TRAILER_LEN]);
        assert!(tx.restarts >= 1, "seed {seed}: the reboot made the sender begin again");
        println!(
            "seed {seed}: {ms} ms, {sent} messages ({:.2}× the minimum), {} timeouts, {} fast go-backs, {} restarts",
            sent as f64 / (image.len().div_ceil(BLOCK_MAX) + 2) as f64,
            tx.timeouts,
            tx.fast_goes_back,
            tx.restarts
        );
    }
}

#[test]
fn a_partition_pauses_and_the_transfer_resumes_where_it_was() {
    let image = signed(30_000);
    let faults = Faults { loss: 0, duplicate: 0, partition: 500..3_000, reboot_at: None };
    let (phase, tx, _, sent, mut dfu) = run(&image, faults, 3);
    assert_eq!((phase, tx.restarts), (Phase::Done, 0), "resumed, not begun again");
    assert_eq!(verify(&mut dfu), Ok(()));
    let blocks = image.len().div_ceil(BLOCK_MAX) as u32;
    assert!(
        sent < blocks + blocks / 4,
        "only what was in flight is sent again: {sent} for {blocks} blocks"
    );
}

#[test]
fn a_bad_image_is_refused_with_its_reason_at_the_end() {
    let mut image = signed(10_000);
    image[4321] ^= 0x80;
    let (phase, ..) =
        run(&image, Faults { loss: 0, duplicate: 0, partition: 0..0, reboot_at: None }, 1);
    assert_eq!(phase, Phase::Refused(Refusal::BadSignature));
    let too_big = vec![0u8; MAP.active.size as usize + 4];
    let (phase, ..) =
        run(&too_big, Faults { loss: 0, duplicate: 0, partition: 0..0, reboot_at: None }, 1);
    assert_eq!(
        phase,
        Phase::Refused(Refusal::TooLarge),
        "refused at the begin, before a byte is written"
    );
}

#[test]
fn messages_round_trip_and_malformed_ones_are_refused() {
    let data = [9u8; BLOCK_MAX];
    let msgs = [
        Msg::Begin { id: 3, len: 56_000 },
        Msg::Block { id: 3, offset: 480, data: &data },
        Msg::End { id: 3 },
        Msg::Status(Status { id: 3, state: State::Refused(Refusal::WrongKind), received: 12 }),
        Msg::Status(Status { id: 3, state: State::Verified, received: 56_000 }),
    ];
    for m in msgs {
        let mut buf = [0; 64];
        let n = m.encode(&mut buf);
        assert!(n <= 64);
        assert_eq!(Msg::decode(&buf[..n]), Ok(m));
        // Cut short, every message is refused, except a block cut after its first data byte:
        // a shorter block (the transfer CRC of RTCAN's multi-frame messages guards its length).
        let whole = if matches!(m, Msg::Block { .. }) { 8 } else { n };
        for cut in 0..whole {
            assert!(Msg::decode(&buf[..cut]).is_err(), "{m:?} cut to {cut} bytes");
        }
    }
    assert!(Msg::decode(&[0x54, 3, 0, 3, 99, 0, 0, 0, 0]).is_err(), "no refusal has code 99");
    assert!(Msg::decode(&[0x52, 3, 0, 0, 0, 0, 0]).is_err(), "a block without data");
    assert!(Msg::decode(&[0x99]).is_err());
}

/// Sends `image` to a fresh receiver in blocks of the sizes `sizes` cycles through (any sender
/// may cut blocks as it likes, up to BLOCK_MAX), ending with `End`.
fn receive_in_blocks(image: &[u8], sizes: &[usize]) -> (Status, Dfu, Status) {
    let mut rx = Receiver::new(MAP.active.size);
    let mut dfu = Dfu::new();
    rx.handle(&Msg::Begin { id: 5, len: image.len() as u32 }, &mut dfu, verify);
    let (mut at, mut i) = (0, 0);
    let mut before_end = rx.status();
    while at < image.len() {
        let n = sizes[i % sizes.len()].min(image.len() - at);
        let block = Msg::Block { id: 5, offset: at as u32, data: &image[at..at + n] };
        before_end = rx.handle(&block, &mut dfu, verify);
        at += n;
        i += 1;
    }
    let end = rx.handle(&Msg::End { id: 5 }, &mut dfu, verify);
    (before_end, dfu, end)
}

#[test]
fn blocks_of_any_size_land_where_they_belong() {
    // Odd sizes start blocks inside a write unit and leave a partial unit pending between them.
    let image = signed(3_001);
    let (_, dfu, end) = receive_in_blocks(&image, &[47, 13, 1, 48, 5]);
    assert_eq!(end.state, State::Verified);
    let (code, trailer) = image.split_at(image.len() - TRAILER_LEN);
    assert_eq!(&dfu.bytes()[..code.len()], code, "the image from the slot's start");
    let t = MAP.active.size as usize - TRAILER_LEN;
    assert_eq!(&dfu.bytes()[t..t + TRAILER_LEN], trailer, "the trailer in the slot's last bytes");
    assert!(dfu.bytes()[code.len()..t].iter().all(|&b| b == 0xFF), "nothing written between");
    // Each page is erased once: the image's three pages and the trailer's.
    assert_eq!(dfu.erases(), 4);
}

#[test]
fn end_before_every_byte_arrived_changes_nothing() {
    let image = signed(2_000);
    let mut rx = Receiver::new(MAP.active.size);
    let mut dfu = Dfu::new();
    rx.handle(&Msg::Begin { id: 6, len: image.len() as u32 }, &mut dfu, verify);
    let first = Msg::Block { id: 6, offset: 0, data: &image[..BLOCK_MAX] };
    rx.handle(&first, &mut dfu, verify);
    let s = rx.handle(&Msg::End { id: 6 }, &mut dfu, verify);
    assert_eq!((s.state, s.received), (State::Receiving, BLOCK_MAX as u32), "still receiving");
}

#[test]
fn begin_checks_the_length_at_its_bounds() {
    let slot = MAP.active.size;
    for (len, want) in [
        (TRAILER_LEN as u32 - 1, State::Refused(Refusal::NoTrailer)),
        (TRAILER_LEN as u32, State::Receiving),
        (slot, State::Receiving),
        (slot + 1, State::Refused(Refusal::TooLarge)),
    ] {
        let mut rx = Receiver::new(slot);
        let s = rx.handle(&Msg::Begin { id: 1, len }, &mut Dfu::new(), verify);
        assert_eq!(s.state, want, "len {len}");
    }
}

#[test]
fn blocks_of_another_transfer_or_after_a_refusal_are_not_taken() {
    let image = signed(1_000);
    let mut rx = Receiver::new(MAP.active.size);
    let mut dfu = Dfu::new();
    rx.handle(&Msg::Begin { id: 7, len: image.len() as u32 }, &mut dfu, verify);
    let stale = Msg::Block { id: 6, offset: 0, data: &image[..BLOCK_MAX] };
    assert_eq!(rx.handle(&stale, &mut dfu, verify).received, 0, "another transfer's block");
    assert_eq!(dfu.erases(), 0, "and nothing written");
    let mut rx = Receiver::new(MAP.active.size);
    rx.handle(&Msg::Begin { id: 8, len: 10 }, &mut dfu, verify); // refused: no trailer
    let block = Msg::Block { id: 8, offset: 0, data: &image[..10] };
    let s = rx.handle(&block, &mut dfu, verify);
    assert_eq!((s.state, s.received), (State::Refused(Refusal::NoTrailer), 0));
}

#[test]
fn progress_is_what_the_receiver_acknowledged_of_the_whole() {
    // What `r2p update`'s progress bar and time estimate show.
    let image = signed(500);
    let len = image.len() as u32;
    let mut tx = Sender::new(&image, 7, 1, 50);
    assert_eq!(tx.progress(), (0, len));
    assert!(matches!(tx.poll(0), Some(Msg::Begin { .. })));
    tx.on_status(&Status { id: 7, state: State::Receiving, received: 0 }, 1);
    assert!(matches!(tx.poll(1), Some(Msg::Block { offset: 0, .. })));
    assert_eq!(tx.progress(), (0, len), "sent is not acknowledged");
    assert!(tx.poll(1).is_none(), "one block in flight: the next waits for its answer");
    let one = BLOCK_MAX as u32;
    tx.on_status(&Status { id: 7, state: State::Receiving, received: one }, 2);
    assert_eq!(tx.progress(), (one, len));
    assert!(matches!(tx.poll(2), Some(Msg::Block { offset, .. }) if offset == one));
}

#[test]
fn a_lost_block_is_sent_again_at_the_second_answer_that_still_waits_for_it() {
    let image = signed(1_000);
    let mut tx = Sender::new(&image, 7, 4, 1_000);
    let at = |received: u32| Status { id: 7, state: State::Receiving, received };
    let block = |m: Option<Msg<'_>>| match m {
        Some(Msg::Block { offset, .. }) => offset,
        other => panic!("expected a block, got {other:?}"),
    };
    assert!(matches!(tx.poll(0), Some(Msg::Begin { .. })));
    tx.on_status(&at(0), 1);
    let b = BLOCK_MAX as u32;
    let sent: Vec<u32> = (0..4).map(|_| block(tx.poll(1))).collect();
    assert_eq!(sent, [0, b, 2 * b, 3 * b], "four blocks in flight");
    assert!(tx.poll(1).is_none());
    tx.on_status(&at(b), 2); // block 0 in
    assert_eq!(block(tx.poll(2)), 4 * b, "the window moves on");
    // Block 1 was lost: blocks 2 and 3 arrive out of order and the receiver still waits at b.
    tx.on_status(&at(b), 3);
    assert!(tx.poll(3).is_none(), "the first such answer may answer a block sent before");
    tx.on_status(&at(b), 4);
    assert_eq!(block(tx.poll(4)), b, "the second: back to the lost block at once");
    assert_eq!((tx.fast_goes_back, tx.timeouts), (1, 0));
    // Answers to the blocks still in flight before the go-back do not send it back again.
    tx.on_status(&at(b), 5);
    tx.on_status(&at(b), 5);
    assert_eq!(block(tx.poll(5)), 2 * b, "it goes on from the resent block");
    assert_eq!(tx.fast_goes_back, 1, "once per gap");
}

#[test]
fn unanswered_begin_and_end_are_sent_again_and_counted_as_timeouts() {
    let image = signed(100);
    let mut tx = Sender::new(&image, 7, 1, 50);
    assert!(matches!(tx.poll(0), Some(Msg::Begin { len, .. }) if len == image.len() as u32));
    assert!(tx.poll(49).is_none(), "within its timeout");
    assert!(matches!(tx.poll(50), Some(Msg::Begin { .. })), "again after it");
    assert_eq!(tx.timeouts, 1, "the first Begin is no timeout, the second is");
    tx.on_status(&Status { id: 7, state: State::Receiving, received: image.len() as u32 }, 51);
    assert_eq!(tx.phase(), Phase::Beginning, "a count before the receiver began is not taken");
    tx.on_status(&Status { id: 7, state: State::Receiving, received: 0 }, 52);
    while tx.phase() == Phase::Sending {
        assert!(matches!(tx.poll(52), Some(Msg::Block { .. })));
        let received = (tx.progress().0 + BLOCK_MAX as u32).min(image.len() as u32);
        tx.on_status(&Status { id: 7, state: State::Receiving, received }, 52);
    }
    assert_eq!(tx.timeouts, 1);
    assert!(matches!(tx.poll(53), Some(Msg::End { id: 7 })));
    assert!(matches!(tx.poll(103), Some(Msg::End { id: 7 })));
    assert_eq!(tx.timeouts, 2);
}

#[test]
fn a_receiver_that_forgot_the_transfer_makes_it_begin_again_under_a_new_id() {
    let image = signed(100);
    let mut tx = Sender::new(&image, 7, 1, 50);
    let idle = Status { id: 0, state: State::Idle, received: 0 };
    tx.poll(0);
    tx.on_status(&idle, 1);
    assert_eq!(tx.restarts, 0, "an idle receiver before it began: still beginning, no restart");
    tx.on_status(&Status { id: 7, state: State::Receiving, received: 0 }, 2);
    assert!(matches!(tx.poll(2), Some(Msg::Block { id: 7, .. })));
    tx.on_status(&Status { id: 3, state: State::Receiving, received: 48 }, 3);
    assert_eq!((tx.phase(), tx.restarts, tx.progress().0), (Phase::Sending, 0, 0), "another's");
    tx.on_status(&idle, 4);
    assert_eq!((tx.phase(), tx.restarts, tx.progress().0), (Phase::Beginning, 1, 0));
    assert!(matches!(tx.poll(4), Some(Msg::Begin { id: 8, .. })), "a new transfer ID");
}

#[test]
fn an_unanswered_block_is_sent_again_after_the_timeout_and_counted() {
    let image = signed(1_000);
    let mut tx = Sender::new(&image, 7, 1, 100);
    let at = |received: u32| Status { id: 7, state: State::Receiving, received };
    assert!(matches!(tx.poll(0), Some(Msg::Begin { .. })));
    tx.on_status(&at(0), 1);
    // Polled late with nothing in flight: no timeout, the first block goes, its clock starts.
    assert!(matches!(tx.poll(500), Some(Msg::Block { offset: 0, .. })));
    assert_eq!(tx.timeouts, 0, "nothing was in flight");
    assert!(tx.poll(599).is_none(), "the window is full and the block within its timeout");
    assert!(matches!(tx.poll(600), Some(Msg::Block { offset: 0, .. })), "sent again after it");
    assert_eq!(tx.timeouts, 1);
    assert!(tx.poll(699).is_none());
    assert!(matches!(tx.poll(700), Some(Msg::Block { offset: 0, .. })));
    assert_eq!(tx.timeouts, 2, "each timeout counted");
}
