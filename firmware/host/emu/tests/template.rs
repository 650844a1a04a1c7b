//! The module template's board (the stub model of a scaffolded module) on the emulated bus:
//! it boots from a robot file, joins the PSU's cycle, and its `template/count` reaches a
//! subscriber on another node.

use r2p_emu::robot::{BoardNode, EmuRobot};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_node::{NoParams, NodeConfig, RemotePublisher};
use r2p_world::robot_file::Robot;
use rtcan::failover::Role;
use rtcan::CycleConfig;

const S: u64 = 1_000_000_000;

fn leak<T>(x: T) -> &'static T {
    Box::leak(Box::new(x))
}

fn robot() -> Robot {
    // diffbot.toml's world and PSU, plus a template module.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/diffbot.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let text = format!(
        "{text}\n[[modules]]\nkind = \"template\"\nname = \"servo\"\nuid = \"0000000000000000000000AA\"\n[modules.params]\nrate_hz = 20\n"
    );
    Robot::parse(&text, "diffbot-with-template.toml").unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_template_board_boots_and_publishes_its_count_on_the_bus() {
    let mut r = EmuRobot::build(robot()).unwrap();
    let topic: &'static Topic<'static, u32, { pool_size(&[64], 1) }, 1> =
        leak(Topic::new("template/count", 0));
    let sub = leak(Subscriber::<u32, 64>::new());
    topic.subscribe(sub).unwrap();
    let import = leak(RemotePublisher::new(leak(Publisher::new(topic, Class::NonRealTime)), topic));
    let cycle = CycleConfig { cycle_us: r.robot.bus.cycle_us, ..CycleConfig::DEFAULT };
    let mut node =
        BoardNode::new(NodeConfig { cycle, ..NodeConfig::new([0x7E; 12], "observer") }, &NoParams)
            .unwrap();
    node.import(import).unwrap();
    let port = r.spare_port();
    r.sim.add_board(node, port, None);

    r.sim.run_until(3 * S);
    let t = r.board("servo").unwrap();
    assert_eq!(r.sim.node(t).role(), Role::Slave);
    assert_eq!(
        r.sim.node(t).peer_count(),
        r.sim.boards() - 1,
        "its heartbeats are seen and it sees every node"
    );
    let counts: Vec<u32> = std::iter::from_fn(|| sub.try_recv().map(|m| *m)).collect();
    // 20 Hz from the robot file's parameter, once subscribed: tens of messages, counting steps.
    assert!(counts.len() >= 20, "{counts:?}");
    assert!(counts.windows(2).all(|w| w[1] == w[0] + 50), "one message per 50 steps: {counts:?}");
}
