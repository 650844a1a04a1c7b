//! The acceptance filters each board programs (r2p_node::hw_filters) on the Triskar2 robot
//! (robots/triskar2.toml): the frames a board's MCU no longer takes in, and the robot still
//! doing what the Triskar2 tests check. Prints the numbers (`--nocapture`).

use r2p_emu::robot::EmuRobot;
use r2p_world::robot_file::Robot;

const S: u64 = 1_000_000_000;

#[test]
fn boards_take_in_only_syncs_management_and_their_subscriptions() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/triskar2.toml");
    let mut r = EmuRobot::build(Robot::load(path).unwrap()).unwrap();
    r.sim.run_until(10 * S);
    let frames: Vec<_> = r.sim.bus().frames().collect();
    let (mut others_total, mut taken_total) = (0u64, 0u64);
    println!("10 s of Triskar2, {} frames on the bus", frames.len());
    println!("board       others' frames   taken in   filtered out in hardware");
    for (i, b) in r.boards.iter().enumerate() {
        let port = r.sim.port_of(i);
        let others = frames.iter().filter(|f| f.1 != port).count() as u64;
        let s = r.sim.node(i).stats();
        let taken = u64::from(s.frames_received);
        println!(
            "{:<11} {others:>14} {taken:>10} {:>10} ({:.1} %)",
            b.name,
            others - taken,
            100.0 * (others - taken) as f64 / others as f64
        );
        // Nothing reaches a board that it must count as unknown: the hardware kept it out.
        assert_eq!(s.unknown_frames, 0, "{}", b.name);
        assert!(taken <= others, "{}", b.name);
        others_total += others;
        taken_total += taken;
    }
    println!(
        "all boards: {} of {others_total} frames filtered out ({:.1} %)",
        others_total - taken_total,
        100.0 * (others_total - taken_total) as f64 / others_total as f64
    );
    // The motor boards subscribe to their setpoints only: most of the bus is not theirs.
    let m = r.board("motor1").or_else(|| r.board("wheel1")).unwrap_or(1);
    let port = r.sim.port_of(m);
    let others = frames.iter().filter(|f| f.1 != port).count() as u32;
    assert!(r.sim.node(m).stats().frames_received < others / 2, "{}", r.boards[m].name);
}
