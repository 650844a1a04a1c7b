//! Firmware updates over the bus on the emulated Triskar2 (issue 18, items 3–4): a tool on the
//! spare port sends a signed image to a motor module with `r2p update`'s sender while the robot
//! drives; the module writes it through its update sink (its flash stalling its CPU as the F103's
//! does), checks it, and after a REBOOT its bootloader swaps it in and it confirms itself. The
//! other modules' HRT traffic keeps its slots; refused images change nothing; an image that
//! never confirms is rolled back; a bus partition pauses the transfer, which then resumes.
//!
//! The gateway (an STM32F407VG: its flash in 128 KiB sectors, each erase stalling its CPU for
//! 1–2 s) takes its own image the same way while the robot drives (the other modules keep their
//! HRT slots; the robot, whose base controller the gateway runs, stops at the first stall: its
//! motors' setpoint watchdogs latch); a motor's image is refused; an image that never confirms is
//! rolled back.

use std::sync::Mutex;

use embassy_boot::State;
use r2p_boot::sender::{Phase, Sender, DEFAULT_WINDOW};
use r2p_boot::sign::{sign, Meta};
use r2p_boot::transfer::{Msg, Status};
use r2p_boot::{image_digest, Refusal, Version};
use r2p_emu::boards::chip::{Erase, Mcu};
use r2p_emu::boards::firmware::{active_trailer, boot_state, development_seed, MCU};
use r2p_emu::robot::{BoardNode, EmuRobot};
use r2p_management::NodeId;
use r2p_node::{NoParams, NodeConfig, UpdateSink};
use r2p_world::robot_file::Robot;
use rtcan::CycleConfig;

const MS: u64 = 1_000_000;
const S: u64 = 1_000 * MS;

fn robot() -> EmuRobot {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/triskar2.toml");
    EmuRobot::build(Robot::load(path).unwrap()).unwrap()
}

/// A signed image of `len` bytes for `kind` on the modules' MCU, version 1.`minor`.0.
fn image(len: usize, kind: &str, minor: u8) -> &'static [u8] {
    image_for(len, kind, minor, MCU)
}

/// A signed image of `len` bytes for `kind` on `mcu`, version 1.`minor`.0.
fn image_for(len: usize, kind: &str, minor: u8, mcu: &str) -> &'static [u8] {
    let bytes: Vec<u8> = (0..len as u32)
        .map(|i| (i ^ 0x5A5A).wrapping_mul(2_654_435_761).to_le_bytes()[2])
        .collect();
    let meta = Meta { version: Version { major: 1, minor, patch: 0 }, kind, mcu };
    Box::leak(sign(&bytes, &meta, &development_seed()).unwrap().into_boxed_slice())
}

/// The statuses the tool hears (its update sink only records).
struct Heard(Mutex<Vec<Status>>);

impl UpdateSink for Heard {
    fn handle(&self, _from: u8, msg: &[u8], _answer: &mut [u8; 64]) -> usize {
        if let Ok(Msg::Status(s)) = Msg::decode(msg) {
            self.0.lock().unwrap().push(s);
        }
        0
    }
}

/// The tool: a node on the spare port with the sender in its application step.
struct Tool {
    board: usize,
    sender: &'static Mutex<Sender<'static>>,
}

fn tool(r: &mut EmuRobot, image: &'static [u8], target: NodeId) -> Tool {
    let heard: &'static Heard = Box::leak(Box::new(Heard(Mutex::new(Vec::new()))));
    let sender: &'static Mutex<Sender<'static>> =
        Box::leak(Box::new(Mutex::new(Sender::new(image, 7, DEFAULT_WINDOW, 400))));
    let mut uid = [0xFFu8; 12];
    uid[11] = 0x51;
    let cycle = CycleConfig { cycle_us: r.robot.bus.cycle_us, ..CycleConfig::DEFAULT };
    let mut node =
        BoardNode::new(NodeConfig { cycle, ..NodeConfig::new(uid, "r2p-cli") }, &NoParams).unwrap();
    node.set_update_sink(heard);
    let app = Box::new(move |now: u64, node: &mut BoardNode| {
        let now_ms = now / 1_000;
        let mut s = sender.lock().unwrap();
        for st in heard.0.lock().unwrap().drain(..) {
            s.on_status(&st, now_ms);
        }
        let mut buf = [0u8; 64];
        while node.tx_pending() < 16 {
            let Some(m) = s.poll(now_ms) else { break };
            let n = m.encode(&mut buf);
            let _ = node.send_update(target, &buf[..n]);
        }
    });
    let port = r.spare_port();
    let board = r.sim.add_board(node, port, Some(app));
    Tool { board, sender }
}

fn phase(t: &Tool) -> Phase {
    t.sender.lock().unwrap().phase()
}

/// Runs until the transfer ends (or `limit_ns`); returns when it ended.
fn run_transfer(r: &mut EmuRobot, t: &Tool, limit_ns: u64) -> u64 {
    let done = |_: &_| matches!(phase(t), Phase::Done | Phase::Refused(_));
    assert!(r.sim.run_while(10 * MS, limit_ns, done), "transfer unfinished: {:?}", phase(t));
    r.sim.now_ns()
}

/// Sends REBOOT to board `m` until it resets, as `r2p update` does: a single frame can be lost
/// while the module's flash stalls it (its receive FIFOs overflow), and it is never answered.
fn reboot(r: &mut EmuRobot, t: &Tool, m: usize) {
    let boots = r.boards[m].boots.get();
    for _ in 0..20 {
        let target = r.sim.node(m).node_id().get();
        r.sim.node_mut(t.board).request_reboot(target).unwrap();
        r.sim.run_for(300 * MS);
        if r.boards[m].boots.get() > boots {
            return;
        }
    }
    panic!("board {m} did not reset on REBOOT");
}

fn node_id(r: &EmuRobot, name: &str) -> NodeId {
    r.sim.node(r.board(name).unwrap()).node_id()
}

fn hrt_missed(r: &EmuRobot, except: usize) -> (u32, u32) {
    let (mut others, mut own) = (0, 0);
    for i in 0..r.boards.len() {
        let m = r.sim.node(i).stats().hrt_missed;
        if i == except {
            own += m;
        } else {
            others += m;
        }
    }
    (others, own)
}

#[test]
fn a_motor_module_takes_an_image_while_the_robot_drives_swaps_it_in_and_confirms_it() {
    let mut r = robot();
    r.sim.run_until(2 * S); // booted, driving (the teleop script starts at 1 s)
    let m = r.board("motor1").unwrap();
    let new = image(24_000, "motor", 4);
    let target = node_id(&r, "motor1");
    let t = tool(&mut r, new, target);
    let start = r.sim.now_ns();
    let frames_before = r.sim.bus().frames().count();
    let end = run_transfer(&mut r, &t, start + 120 * S);
    assert_eq!(phase(&t), Phase::Done);
    let (others, own) = hrt_missed(&r, m);
    assert_eq!(others, 0, "every other module's HRT traffic kept its slots during the transfer");
    let secs = (end - start) as f64 / S as f64;
    let frames = r.sim.bus().frames().count() - frames_before;
    let update_frames = r
        .sim
        .bus()
        .frames()
        .skip(frames_before)
        .filter(|(_, p, f)| {
            // The tool's management stream and motor1's answers to it.
            let id = f.id().message.0;
            *p == t.board || (*p == m && id & 0xFF == 0)
        })
        .count();
    let s = t.sender.lock().unwrap();
    println!(
        "update of {} B to motor1 while driving: {secs:.1} s virtual ({:.1} KiB/s), {} timeouts, \
         {} goes back; {update_frames} of {frames} frames on the bus were the update's; \
         motor1's own HRT streams: {} frames sent, {own} slots missed",
        new.len(),
        new.len() as f64 / 1024.0 / secs,
        s.timeouts,
        s.fast_goes_back,
        r.sim.node(m).stats().hrt_sent
    );
    drop(s);
    assert_eq!(boot_state(r.boards[m].flash), Some(State::Swap), "marked for the swap");
    assert_eq!(active_trailer(r.boards[m].flash).unwrap().version.minor, 1, "still the old image");
    // REBOOT: the bootloader swaps (the board is off the bus meanwhile), the image confirms.
    let boots = r.boards[m].boots.get();
    reboot(&mut r, &t, m);
    r.sim.run_for(25 * S);
    assert_eq!(r.boards[m].boots.get(), boots + 1, "rebooted once");
    let now = active_trailer(r.boards[m].flash).unwrap();
    assert_eq!((now.version.minor, now.digest), (4, image_digest(&new[..new.len() - 128])));
    assert_eq!(boot_state(r.boards[m].flash), Some(State::Boot), "confirmed: no rollback");
    assert_eq!(r.sim.node(m).peer_count(), r.sim.boards() - 1, "back on the bus");
}

#[test]
fn refused_images_change_nothing_and_say_why() {
    for (what, img, why) in [
        ("another kind", image(6_000, "psu", 4), Refusal::WrongKind),
        ("too large", image(60_000, "motor", 4), Refusal::TooLarge),
        ("a flipped byte", flipped(image(6_000, "motor", 4), 4_321), Refusal::BadSignature),
    ] {
        let mut r = robot();
        r.sim.run_until(2 * S);
        let m = r.board("motor1").unwrap();
        let target = node_id(&r, "motor1");
        let t = tool(&mut r, img, target);
        run_transfer(&mut r, &t, 120 * S);
        assert_eq!(phase(&t), Phase::Refused(why), "{what}");
        assert_eq!(boot_state(r.boards[m].flash), Some(State::Boot), "{what}: nothing marked");
        reboot(&mut r, &t, m);
        r.sim.run_for(3 * S);
        assert_eq!(
            active_trailer(r.boards[m].flash).unwrap().version.minor,
            1,
            "{what}: old image"
        );
    }
}

fn flipped(img: &'static [u8], at: usize) -> &'static [u8] {
    let mut v = img.to_vec();
    v[at] ^= 0x10;
    Box::leak(v.into_boxed_slice())
}

#[test]
fn a_new_image_that_never_confirms_is_rolled_back() {
    let mut r = robot();
    r.sim.run_until(2 * S);
    let m = r.board("motor1").unwrap();
    let target = node_id(&r, "motor1");
    let t = tool(&mut r, image(12_000, "motor", 4), target);
    run_transfer(&mut r, &t, 120 * S);
    assert_eq!(phase(&t), Phase::Done);
    // The new image boots cut off from the bus: it never hears the master's sync.
    reboot(&mut r, &t, m);
    r.sim.bus().partition(&[m]);
    r.sim.run_for(10 * S);
    assert_eq!(active_trailer(r.boards[m].flash).unwrap().version.minor, 4, "swapped in, on trial");
    r.sim.run_for(20 * S); // past the trial's 15 s: it resets, the bootloader swaps back
    r.sim.bus().heal();
    r.sim.run_for(15 * S);
    assert_eq!(active_trailer(r.boards[m].flash).unwrap().version.minor, 1, "rolled back");
    assert_eq!(boot_state(r.boards[m].flash), Some(State::Boot), "and the old image kept");
}

#[test]
fn a_transfer_cut_by_a_bus_partition_resumes_where_it_stood() {
    let mut r = robot();
    r.sim.run_until(2 * S);
    let m = r.board("motor1").unwrap();
    let target = node_id(&r, "motor1");
    let t = tool(&mut r, image(30_000, "motor", 4), target);
    r.sim.run_for(2 * S);
    let before = t.sender.lock().unwrap().progress().0;
    assert!(before > 0 && phase(&t) == Phase::Sending, "under way: {before} B of 30 128");
    r.sim.bus().partition(&[m]);
    r.sim.run_for(2 * S);
    r.sim.bus().heal();
    let limit = r.sim.now_ns() + 120 * S;
    run_transfer(&mut r, &t, limit);
    let s = t.sender.lock().unwrap();
    assert_eq!((s.phase(), s.restarts), (Phase::Done, 0), "resumed, not begun again");
    assert!(s.timeouts > 0, "the partition was felt");
}

/// The gateway's image: about the size of the committed one (firmware/images/gateway.bin).
const GATEWAY_IMAGE_LEN: usize = 124_000;

fn gateway_image(len: usize, kind: &str, minor: u8) -> &'static [u8] {
    image_for(len, kind, minor, Mcu::F407.spec().name)
}

/// The erases board `b`'s flash did from the `from`th on.
fn erases_since(r: &EmuRobot, b: usize, from: usize) -> Vec<Erase> {
    r.boards[b].flash.lock(|c| c.borrow().erases[from..].to_vec())
}

/// The robot's pose at `t_ns` when nothing is updated.
fn pose_without_update(t_ns: u64) -> r2p_world::Pose {
    let mut r = robot();
    r.sim.run_until(t_ns);
    let pose = r.world.borrow().pose();
    pose
}

fn erase_count(r: &EmuRobot, b: usize) -> usize {
    r.boards[b].flash.lock(|c| c.borrow().erases.len())
}

#[test]
fn the_gateway_takes_its_image_while_the_robot_drives_swaps_it_in_and_confirms_it() {
    let mut r = robot();
    r.sim.run_until(2 * S);
    let g = r.board("gateway").unwrap();
    let new = gateway_image(GATEWAY_IMAGE_LEN, "gateway", 4);
    let target = node_id(&r, "gateway");
    let t = tool(&mut r, new, target);
    let (start, erases_before) = (r.sim.now_ns(), erase_count(&r, g));
    let end = run_transfer(&mut r, &t, start + 300 * S);
    assert_eq!(phase(&t), Phase::Done);
    let (others, own) = hrt_missed(&r, g);
    assert_eq!(others, 0, "every other module's HRT traffic kept its slots during the transfer");
    let erases = erases_since(&r, g, erases_before);
    // Its first slot sector, the trailer's, and the state sector for the mark.
    let sizes: Vec<u32> = erases.iter().map(|e| e.size / 1024).collect();
    assert_eq!(sizes, [128, 128, 64], "sectors erased by the transfer (KiB)");
    // The gateway's longest silence on the bus meanwhile: its CPU stalled by an erase.
    let sent: Vec<u64> = r.sim.bus().frames().filter(|f| f.1 == g).map(|f| f.0).collect();
    let silence = sent.windows(2).filter(|w| w[0] >= start).map(|w| w[1] - w[0]).max().unwrap();
    // Where the robot is (it turned and slid meanwhile), against the same robot not updated.
    let (p, q) = (r.world.borrow().pose(), pose_without_update(end));
    let secs = (end - start) as f64 / S as f64;
    let s = t.sender.lock().unwrap();
    println!(
        "after the transfer the robot stood {:.3} m and {:.1}° from where it stands without the \
         update (the gateway's base controller stalled with it)",
        (p.x - q.x).hypot(p.y - q.y),
        (p.theta - q.theta).to_degrees()
    );
    println!(
        "update of {} B to the gateway while driving: {secs:.1} s virtual ({:.1} KiB/s), {} \
         timeouts, {} goes back; erase stalls {:?} ms; HRT slots missed: {others} by the \
         others, {own} by the gateway (its setpoints, {} sent); the gateway silent on the bus for \
         up to {} ms",
        new.len(),
        new.len() as f64 / 1024.0 / secs,
        s.timeouts,
        s.fast_goes_back,
        erases.iter().map(|e| e.ns / MS).collect::<Vec<_>>(),
        r.sim.node(g).stats().hrt_sent,
        silence / MS,
    );
    drop(s);
    assert_eq!(boot_state(r.boards[g].flash), Some(State::Swap), "marked for the swap");
    assert_eq!(active_trailer(r.boards[g].flash).unwrap().version.minor, 1, "still the old image");
    // REBOOT: the bootloader swaps three 128 KiB sectors (the gateway is off the bus meanwhile),
    // the image confirms itself.
    let boots = r.boards[g].boots.get();
    let before_swap = erase_count(&r, g);
    reboot(&mut r, &t, g);
    let swap_start = r.sim.now_ns();
    r.sim.run_while(100 * MS, swap_start + 60 * S, |sim| sim.node(g).peer_count() > 0);
    let swap_ms: u64 = erases_since(&r, g, before_swap).iter().map(|e| e.ns / MS).sum();
    r.sim.run_for(20 * S);
    println!("the swap erased for {swap_ms} ms; the gateway was back after {} ms", {
        (r.sim.now_ns() - 20 * S - swap_start) / MS
    });
    assert_eq!(r.boards[g].boots.get(), boots + 1, "rebooted once");
    let now = active_trailer(r.boards[g].flash).unwrap();
    assert_eq!((now.version.minor, now.digest), (4, image_digest(&new[..new.len() - 128])));
    assert_eq!(boot_state(r.boards[g].flash), Some(State::Boot), "confirmed: no rollback");
    assert_eq!(r.sim.node(g).peer_count(), r.sim.boards() - 1, "back on the bus");
}

#[test]
fn the_gateway_refuses_a_motor_image_and_keeps_its_own() {
    let motor_on_f407 = gateway_image(6_000, "motor", 4);
    for (what, img, why) in [
        ("a motor's image", image(6_000, "motor", 4), Refusal::WrongMcu),
        ("a motor image for its MCU", motor_on_f407, Refusal::WrongKind),
        ("too large", gateway_image(400_000, "gateway", 4), Refusal::TooLarge),
    ] {
        let mut r = robot();
        r.sim.run_until(2 * S);
        let g = r.board("gateway").unwrap();
        let target = node_id(&r, "gateway");
        let t = tool(&mut r, img, target);
        run_transfer(&mut r, &t, 120 * S);
        assert_eq!(phase(&t), Phase::Refused(why), "{what}");
        assert_eq!(boot_state(r.boards[g].flash), Some(State::Boot), "{what}: nothing marked");
        reboot(&mut r, &t, g);
        r.sim.run_for(3 * S);
        let running = active_trailer(r.boards[g].flash).unwrap();
        assert_eq!((running.version.minor, running.kind.as_str()), (1, "gateway"), "{what}");
    }
}

#[test]
fn a_gateway_image_that_never_confirms_is_rolled_back() {
    let mut r = robot();
    r.sim.run_until(2 * S);
    let g = r.board("gateway").unwrap();
    let target = node_id(&r, "gateway");
    let t = tool(&mut r, gateway_image(12_000, "gateway", 4), target);
    run_transfer(&mut r, &t, 120 * S);
    assert_eq!(phase(&t), Phase::Done);
    // The new image boots cut off from the bus: master of nobody, it never confirms.
    reboot(&mut r, &t, g);
    r.sim.bus().partition(&[g]);
    r.sim.run_for(20 * S); // the swap: 9–15 s
    assert_eq!(active_trailer(r.boards[g].flash).unwrap().version.minor, 4, "swapped in, on trial");
    r.sim.run_for(35 * S); // past the trial's 15 s: it resets, the bootloader swaps back
    r.sim.bus().heal();
    r.sim.run_for(10 * S);
    assert_eq!(active_trailer(r.boards[g].flash).unwrap().version.minor, 1, "rolled back");
    assert_eq!(boot_state(r.boards[g].flash), Some(State::Boot), "and the old image kept");
    assert_eq!(r.sim.node(g).peer_count(), r.sim.boards() - 1, "back on the bus");
}
