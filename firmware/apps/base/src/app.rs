//! The base controller's step: IK, obstacle avoidance, odometry.

use r2p_module::trig::{cosf, sinf};
use r2p_module::TopicNode;
use r2p_msgs::{Odometry, Twist2D, WheelSetpoint};
use r2p_node::{Export, Import, NodeError, ParamStore, Typed};

use crate::kinematics::Omni3;
use crate::params as p;

/// Speed mode of [`WheelSetpoint`].
const MODE_SPEED: u8 = 1;

/// The application's view of its topics (see `Endpoints`).
pub struct Ends<'a> {
    cmd: &'a r2p_middleware::Subscriber<'a, Twist2D, 2>,
    obstacle: &'a r2p_middleware::Subscriber<'a, r2p_msgs::Obstacle, 4>,
    ranges: &'a r2p_middleware::Subscriber<'a, r2p_msgs::Proximity, 2>,
    states: [&'a r2p_middleware::Subscriber<'a, r2p_msgs::WheelState, 2>; 3],
    setpoints: [&'a r2p_middleware::Publisher<'a, WheelSetpoint>; 3],
    odom: &'a r2p_middleware::Publisher<'a, Odometry>,
    exports: [&'a dyn Export; 4],
    imports: [&'a dyn Import; 6],
}

/// The base controller.
pub struct App<'a> {
    ends: Ends<'a>,
    params: &'a dyn ParamStore,
    cmd: Twist2D,
    cmd_at_us: Option<u64>,
    /// Per proximity channel: until when an obstacle in its direction blocks motion.
    blocked: [u64; 4],
    wheels: [f32; 3],
    pose: (f32, f32, f32),
    velocity: (f32, f32, f32),
    next_ik_us: u64,
    next_odom_us: u64,
    last_odom_us: Option<u64>,
    last_ranges: Option<r2p_msgs::Proximity>,
    /// Setpoints the pool had no room for (the bus is behind).
    pub dropped: u32,
}

impl<'a> App<'a> {
    /// The parameters as the application reads them (defaults from the table).
    fn typed(&self) -> Typed<'a> {
        Typed::new(self.params, &crate::params::DEFAULTS)
    }

    /// The application over `ends` with parameters from `params` (read every step, so a
    /// PARAM_SET applies at once; the topics' names and the setpoints' period were read when
    /// `ends` was built).
    pub fn new(ends: crate::Endpoints<'a>, params: &'a dyn ParamStore) -> Self {
        let ends = Ends {
            cmd: ends.cmd,
            obstacle: ends.obstacle,
            ranges: ends.ranges,
            states: ends.states,
            setpoints: ends.setpoints,
            odom: ends.odom,
            exports: ends.exports,
            imports: ends.imports,
        };
        Self {
            ends,
            params,
            cmd: Twist2D::default(),
            cmd_at_us: None,
            blocked: [0; 4],
            wheels: [0.0; 3],
            pose: (0.0, 0.0, 0.0),
            velocity: (0.0, 0.0, 0.0),
            next_ik_us: 0,
            next_odom_us: 0,
            last_odom_us: None,
            last_ranges: None,
            dropped: 0,
        }
    }

    /// Exports the setpoints and odometry, imports the command, obstacles and wheel states.
    pub fn register(&self, node: &mut impl TopicNode<'a>) -> Result<(), NodeError> {
        for e in self.ends.exports {
            node.export(e)?;
        }
        for i in self.ends.imports {
            node.import(i)?;
        }
        Ok(())
    }

    fn geometry(&self) -> Omni3 {
        Omni3 {
            wheel_radius: self.typed().f32(p::WHEEL_RADIUS),
            base_radius: self.typed().f32(p::BASE_RADIUS),
            first_wheel: self.typed().f32(p::FIRST_WHEEL_DEG).to_radians(),
        }
    }

    /// The command after obstacle avoidance (what the wheels are asked for).
    pub fn command(&self, now_us: u64) -> Twist2D {
        let timeout = u64::from(self.typed().u32(p::CMD_TIMEOUT_MS)) * 1000;
        let mut c = match self.cmd_at_us {
            Some(t) if now_us.saturating_sub(t) <= timeout => self.cmd,
            _ => return Twist2D::default(),
        };
        for (ch, until) in self.blocked.iter().enumerate() {
            if now_us >= *until {
                continue;
            }
            let a = self.typed().f32(p::CHANNEL0_DEG + ch as u16).to_radians();
            let (ux, uy) = (cosf(a), sinf(a));
            let towards = c.vx * ux + c.vy * uy;
            if towards > 0.0 {
                // Listing 2's avoidCollision: keep the motion along the obstacle, drop the
                // part heading into it.
                c.vx -= towards * ux;
                c.vy -= towards * uy;
            }
        }
        c
    }

    /// Pose (x, y, θ) by odometry.
    pub fn pose(&self) -> (f32, f32, f32) {
        self.pose
    }

    /// The latest ranges received from the proximity module, if any.
    pub fn ranges(&self) -> Option<r2p_msgs::Proximity> {
        self.last_ranges
    }

    /// Velocity (vx, vy, ωz) in the base frame by forward kinematics of the wheels' speeds.
    pub fn velocity(&self) -> (f32, f32, f32) {
        self.velocity
    }

    /// One step at `now_us` (every millisecond).
    pub fn step(&mut self, now_us: u64) {
        while let Some(c) = self.ends.cmd.try_recv() {
            self.cmd = *c;
            self.cmd_at_us = Some(now_us);
        }
        let stop = self.typed().f32(p::STOP_DISTANCE);
        let until = now_us + u64::from(self.typed().u32(p::OBSTACLE_HOLD_MS)) * 1000;
        // The event reacts at once (soft real time); the periodic ranges keep the block while
        // the obstacle stays (the event is not repeated).
        while let Some(o) = self.ends.obstacle.try_recv() {
            if o.distance.is_finite() && o.distance < stop {
                self.blocked[usize::from(o.channel.min(3))] = until;
            }
        }
        while let Some(r) = self.ends.ranges.try_recv() {
            self.last_ranges = Some(*r);
            for ch in 0..4 {
                if r.status[ch] == 0 && r.distance[ch].is_finite() && r.distance[ch] < stop {
                    self.blocked[ch] = until;
                }
            }
        }
        for (i, s) in self.ends.states.iter().enumerate() {
            while let Some(m) = s.try_recv() {
                self.wheels[i] = m.speed;
            }
        }
        if now_us >= self.next_ik_us {
            let period = 1_000_000 / u64::from(self.typed().u32(p::IK_RATE_HZ).max(1));
            self.next_ik_us = now_us - now_us % period + period;
            let c = self.command(now_us);
            let w = self.geometry().inverse(c.vx, c.vy, c.wz);
            for (publisher, value) in self.ends.setpoints.iter().zip(w) {
                if publisher
                    .publish_with(|m| *m = WheelSetpoint { mode: MODE_SPEED, value })
                    .is_none()
                {
                    self.dropped += 1;
                }
            }
        }
        self.integrate(now_us);
        if now_us >= self.next_odom_us {
            let period = 1_000_000 / u64::from(self.typed().u32(p::ODOM_RATE_HZ).max(1));
            self.next_odom_us = now_us - now_us % period + period;
            let (x, y, theta) = self.pose;
            let (vx, vy, wz) = self.velocity;
            let _ = self.ends.odom.publish_with(|m| *m = Odometry { x, y, theta, vx, vy, wz });
        }
    }

    fn integrate(&mut self, now_us: u64) {
        let dt = match self.last_odom_us.replace(now_us) {
            Some(t) => (now_us - t) as f32 * 1e-6,
            None => return,
        };
        let (vx, vy, wz) = self.geometry().forward(self.wheels);
        self.velocity = (vx, vy, wz);
        let (x, y, th) = self.pose;
        // Midpoint heading: exact for constant velocity over the step to second order.
        let mid = th + 0.5 * wz * dt;
        let (s, c) = (sinf(mid), cosf(mid));
        self.pose = (x + (c * vx - s * vy) * dt, y + (s * vx + c * vy) * dt, th + wz * dt);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::endpoints::Endpoints;
    use crate::names::Names;
    use r2p_node::RamParams;
    use std::boxed::Box;

    fn rig() -> (App<'static>, &'static RamParams<{ p::COUNT }>) {
        let params: &'static RamParams<{ p::COUNT }> =
            Box::leak(Box::new(RamParams::new(p::DEFAULTS)));
        let ends = Endpoints::leak(Names::from_params(params), 10_000);
        (App::new(ends, params), params)
    }

    #[test]
    fn a_command_holds_until_it_times_out() {
        let (mut app, _) = rig();
        app.cmd = Twist2D { vx: 0.5, vy: 0.0, wz: 0.0 };
        app.cmd_at_us = Some(0);
        let c = app.command(100_000);
        assert_eq!((c.vx, c.vy), (0.5, 0.0));
        assert_eq!(app.command(600_001).vx, 0.0, "older than cmd_timeout_ms: stop");
    }

    #[test]
    fn an_obstacle_ahead_removes_only_the_motion_towards_it() {
        let (mut app, _) = rig();
        app.cmd = Twist2D { vx: 0.4, vy: 0.3, wz: 0.2 };
        app.cmd_at_us = Some(0);
        app.blocked[0] = 300_000; // channel 0 faces +x
        let c = app.command(1_000);
        assert!(c.vx.abs() < 1e-6 && (c.vy - 0.3).abs() < 1e-6 && (c.wz - 0.2).abs() < 1e-6);
        app.cmd = Twist2D { vx: -0.4, vy: 0.0, wz: 0.0 };
        assert_eq!(app.command(1_000).vx, -0.4, "backing away is allowed");
        app.cmd = Twist2D { vx: 0.4, vy: 0.0, wz: 0.0 };
        assert_eq!(app.command(300_001).vx, 0.4, "the hold expired");
    }

    #[test]
    fn odometry_integrates_a_circle() {
        let (mut app, _) = rig();
        let g = app.geometry();
        // Drive a circle: 0.5 m/s forward, 1 rad/s: radius 0.5 m, back home after 2π s.
        app.wheels = g.inverse(0.5, 0.0, 1.0);
        let steps = (2.0 * core::f64::consts::PI * 1000.0).round() as u64;
        for t in 0..=steps {
            app.integrate(t * 1000);
        }
        let (x, y, th) = app.pose();
        assert!(x.abs() < 0.01 && y.abs() < 0.01, "back at the start: {x} {y}");
        assert!((th - 2.0 * core::f32::consts::PI).abs() < 0.01, "{th}");
    }
}
