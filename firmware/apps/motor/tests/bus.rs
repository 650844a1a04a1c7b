//! Two motor controllers and a gateway on a loopback CAN bus, in one process: the
//! boards' topics are their own, setpoints and states cross the bus, and parameters are set
//! (or refused) over it.

mod common;

use common::Motor;
use r2p_app_motor::params::{self, index, COUNT};
use r2p_app_motor::{App, Endpoints, Names};
use r2p_management::message::{ParamFault, Value};
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};
use r2p_msgs::{WheelSetpoint, WheelState};
use r2p_node::{
    Event, NoParams, Node, NodeConfig, ParamStore, RamParams, RemotePublisher, RemoteSubscriber,
};
use rtcan::controller::{BusState, ErrorCounters, Filter, Received, TxError};
use rtcan::{CanController, Frame};
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::rc::Rc;

/// A loopback CAN bus: a frame one port sends reaches every other port at once, in the order
/// it was sent (the FIFO order the node asks of its controller), stamped with the bus's time.
#[derive(Clone, Default)]
struct Bus {
    queues: Rc<RefCell<Vec<VecDeque<Received>>>>,
    now: Rc<Cell<u64>>,
}

impl Bus {
    fn new(ports: usize) -> Self {
        let bus = Self::default();
        bus.queues.borrow_mut().resize(ports, VecDeque::new());
        bus
    }

    fn port(&self, me: usize) -> Port {
        Port { bus: self.clone(), me, done: Default::default() }
    }
}

struct Port {
    bus: Bus,
    me: usize,
    /// Every frame goes out at once: its result is `Sent`.
    done: std::collections::VecDeque<rtcan::controller::TxResult>,
}

impl CanController for Port {
    fn try_transmit(&mut self, frame: &Frame) -> Result<(), TxError> {
        let at = self.bus.now.get();
        for (i, q) in self.bus.queues.borrow_mut().iter_mut().enumerate() {
            if i != self.me {
                q.push_back(Received { frame: *frame, at });
            }
        }
        self.done.push_back(rtcan::controller::TxResult::new(
            frame.id(),
            rtcan::controller::TxOutcome::Sent,
        ));
        Ok(())
    }
    fn set_tx_mode(&mut self, _: rtcan::controller::TxMode) {}
    fn take_tx_result(&mut self) -> Option<rtcan::controller::TxResult> {
        self.done.pop_front()
    }
    fn try_receive(&mut self) -> Option<Received> {
        self.bus.queues.borrow_mut()[self.me].pop_front()
    }
    fn set_filters(&mut self, _: &[Filter]) {}
    fn abort_pending(&mut self) -> usize {
        0
    }
    fn bus_state(&self) -> BusState {
        BusState::ErrorActive
    }
    fn error_counters(&self) -> ErrorCounters {
        ErrorCounters::default()
    }
}

type BoardNode = Node<'static, 4, 4, 32, 4, 64>;

fn leak<T>(v: T) -> &'static T {
    Box::leak(Box::new(v))
}

fn uid(n: u32) -> [u8; 12] {
    let mut u = [0u8; 12];
    u[8..].copy_from_slice(&n.to_be_bytes());
    u
}

struct Board {
    app: App<'static>,
    node: BoardNode,
    params: &'static RamParams<COUNT>,
    motor: Motor,
    port: Port,
}

impl Board {
    fn new(bus: &Bus, port: usize, instance: u32) -> Self {
        let params = leak(RamParams::new(params::DEFAULTS));
        params.set(index::INSTANCE, Value::U32(instance)).unwrap();
        let names = Names::from_params(params);
        let app = App::new(Endpoints::leak(names), params);
        let mut node =
            Node::new(NodeConfig::new(uid(port as u32 + 1), names.node), params).unwrap();
        app.register(&mut node).unwrap();
        Self { app, node, params, motor: Motor::default(), port: bus.port(port) }
    }

    fn step(&mut self, now_us: u64) {
        let cmd = self.app.step(now_us, &self.motor.sample());
        self.motor.advance(&cmd, 1e-3);
    }
}

/// The gateway's side of one motor: it publishes setpoints and receives states.
struct Wheel {
    setpoint: &'static Publisher<'static, WheelSetpoint>,
    states: &'static Subscriber<'static, WheelState, 4>,
}

fn wheel(gw: &mut Node<'static, 4, 4, 32, 4, 64>, name: &Names) -> Wheel {
    let sp: &'static Topic<'static, WheelSetpoint, { pool_size(&[2], 1) }, 1> =
        leak(Topic::new(name.setpoint, WheelSetpoint::default()));
    let sp_pub = leak(Publisher::new(sp, Class::NonRealTime));
    let sp_out = leak(RemoteSubscriber::<'static, WheelSetpoint, 2>::new(sp_pub));
    sp.advertise(sp_pub).unwrap();
    sp.subscribe(sp_out).unwrap();
    let st: &'static Topic<'static, WheelState, { pool_size(&[4], 1) }, 1> =
        leak(Topic::new(name.state, WheelState::default()));
    let st_pub = leak(Publisher::new(st, Class::NonRealTime));
    let st_in = leak(RemotePublisher::new(st_pub, st));
    let states = leak(Subscriber::new());
    st.advertise(st_pub).unwrap();
    st.subscribe(states).unwrap();
    gw.export(sp_out).unwrap();
    gw.import(st_in).unwrap();
    Wheel { setpoint: sp_pub, states }
}

#[test]
fn a_gateway_drives_two_motors_over_the_bus_and_parameters_are_range_checked() {
    let bus = Bus::new(3);
    let mut boards = [Board::new(&bus, 0, 1), Board::new(&bus, 1, 3)];
    assert_eq!(boards[1].app.names().state, "motor3/state");
    let mut gw: BoardNode = Node::new(NodeConfig::new(uid(9), "gateway"), leak(NoParams)).unwrap();
    let wheels = [wheel(&mut gw, &Names::of(1)), wheel(&mut gw, &Names::of(3))];
    let mut gw_port = bus.port(2);
    let targets = [6.0f32, -9.0];
    let mut counts = [[0u32; 3]; 2]; // states received per wheel in three windows
    let mut last = [WheelState::default(); 2];
    let mut answers = Vec::new();
    for ms in 0..3000u64 {
        let now = ms * 1000;
        bus.now.set(now);
        for b in boards.iter_mut() {
            b.node.poll(now, &mut b.port);
        }
        gw.poll(now, &mut gw_port);
        for b in boards.iter_mut() {
            b.step(now);
        }
        if ms >= 500 && ms % 10 == 0 {
            for (w, t) in wheels.iter().zip(targets) {
                w.setpoint.publish_with(|m| *m = WheelSetpoint { mode: 1, value: t }).unwrap();
            }
        }
        if ms == 1500 {
            let motor1 = boards[0].node.node_id();
            gw.set_param(motor1, index::SPEED_KP, Value::F32(1000.0)).unwrap();
            gw.set_param(motor1, index::PUBLISH_HZ, Value::U32(50)).unwrap();
        }
        while let Some(e) = gw.next_event() {
            if let Event::ParamValue { index, .. } | Event::ParamError { index, .. } = e {
                answers.push((index, e));
            }
        }
        let window = match ms {
            1000..2000 => 0,
            2000..3000 => 1,
            _ => 2,
        };
        for (k, w) in wheels.iter().enumerate() {
            while let Some(s) = w.states.try_recv() {
                counts[k][window] += 1;
                last[k] = *s;
            }
        }
    }
    // Each motor runs at its own setpoint: the boards share no topic.
    for (k, t) in targets.iter().enumerate() {
        assert!((last[k].speed - t).abs() < 0.1, "wheel {k}: {:?}", last[k]);
        assert!((f64::from(last[k].speed) - boards[k].motor.output_speed()).abs() < 0.1);
        assert_eq!(last[k].faults, 0);
    }
    // 100 Hz until the gateway set motor1's publish_hz to 50 (at 1.5 s).
    assert!((99..=101).contains(&counts[1][0]), "motor3, 1–2 s: {}", counts[1][0]);
    assert!((99..=101).contains(&counts[1][1]), "motor3, 2–3 s: {}", counts[1][1]);
    assert!(
        (74..=77).contains(&counts[0][0]),
        "motor1, 1–2 s (100 Hz then 50 Hz): {}",
        counts[0][0]
    );
    assert!((49..=51).contains(&counts[0][1]), "motor1, 2–3 s: {}", counts[0][1]);
    // The out-of-range gain was refused with the reason and not applied.
    assert!(
        answers.iter().any(|(i, e)| *i == index::SPEED_KP
            && matches!(e, Event::ParamError { fault: ParamFault::OutOfRange, .. })),
        "{answers:?}"
    );
    assert_eq!(boards[0].params.get(index::SPEED_KP), Ok(Value::F32(2.6)));
    assert!(answers.iter().any(|(i, e)| *i == index::PUBLISH_HZ
        && matches!(e, Event::ParamValue { value: Value::U32(50), .. })));
    for b in &boards {
        assert_eq!(b.node.stats().deadline_misses, 0);
    }
}
