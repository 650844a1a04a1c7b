//! The Triskar2 robot file on emulated boards: every module's firmware against the world.

use r2p_emu::robot::EmuRobot;

const MS: u64 = 1_000_000;

fn robot() -> EmuRobot {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/triskar2.toml");
    EmuRobot::load(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn explore() {
    let mut r = robot();
    for t in 0..100 {
        r.sim.run_until((t + 1) * 100 * MS);
        let w = r.world.borrow();
        let p = w.pose();
        let pr = r.probe.borrow();
        println!(
            "t={:.1} pose=({:.3},{:.3},{:.1}°) odom=({:.3},{:.3},{:.1}°) cmd={:?} wheels={:?}",
            (t + 1) as f64 / 10.0,
            p.x,
            p.y,
            p.theta.to_degrees(),
            pr.odometry.0,
            pr.odometry.1,
            pr.odometry.2.to_degrees(),
            pr.command,
            (0..3).map(|k| format!("{:.1}", w.wheel(k).motor_speed)).collect::<Vec<_>>()
        );
    }
    for i in 0..r.sim.boards() {
        println!("{} {:?} {:?}", r.boards[i].name, r.sim.node(i).role(), r.sim.node(i).stats());
    }
}

#[test]
fn explore_imports() {
    let mut r = robot();
    r.sim.run_until(3_000 * MS);
    let g = r.board("gateway").unwrap();
    for i in 0..5 {
        println!("gateway import {i}: {:?}", r.sim.node(g).import_state(i));
    }
    for i in 0..r.sim.boards() {
        println!("{} hrt {:?} peers {}", r.boards[i].name, r.sim.node(i).hrt_state(0), r.sim.node(i).peer_count());
    }
}

#[test]
fn explore_motor3() {
    let mut r = robot();
    let m = r.board("motor3").unwrap();
    for t in 0..30 {
        r.sim.run_until((t + 1) * 100 * MS);
        let n = r.sim.node(m);
        let s = n.stats();
        println!("t={} pending={} sent={} overflow={} retries={} id={:?} role={:?}", t, n.tx_pending(), s.frames_sent, s.tx_overflow, s.slot_retries, n.node_id(), n.role());
    }
}
