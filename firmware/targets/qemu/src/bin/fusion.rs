//! Cortex-M3 benchmark under QEMU (run by `scripts/bench`, not by the test suite): instructions
//! per step of the IMU module's estimators (`r2p-app-imu`), in soft float as on the F103:
//! the quaternion filter with and without a magnetometer sample, the barometric altitude, the
//! run-time parameters' read (`Config::read`: 27 values from the RAM copy `FlashParams`
//! serves), and as the baseline the Euler-angle complementary filter the module ran before
//! issue 21.
//!
//! Counted as `bench` counts (SysTick under `-icount`, calibrated on 10 000 `nop`s). Inputs
//! vary from step to step (a turning, slightly tilted body) so that no branch is always taken
//! the same way; a checksum of the outputs keeps the work from being optimised away.
#![no_std]
#![no_main]

use core::fmt::Write;
use core::hint::black_box;

use cortex_m_semihosting::{debug, hio};
use r2p_app_imu::ahrs::{Ahrs, Gains};
use r2p_app_imu::altitude::{isa_altitude, Vertical};
use r2p_app_imu::attitude::Attitude;
use r2p_app_imu::params::{Config, DEFAULTS};
use r2p_node::RamParams;
use r2p_qemu_tests::icount::{self, ten_thousand_nops, ticks};

const STEPS: u32 = 1_000;
const G: f32 = 9.806_65;
const GAINS: Gains =
    Gains { tilt_tau_s: 2.0, heading_tau_s: 5.0, bias_tau_s: 100.0, accel_gate: 0.1 };

/// The i-th sample: a body turning at 0.3 rad/s with a small wobble, gravity a little off z.
fn sample(i: u32) -> ([f32; 3], [f32; 3], [f32; 3]) {
    let w = (i % 64) as f32 * 1e-3;
    let gyro = [0.01 + w, -0.02 + w, 0.3];
    let accel = [0.3 - w, 0.2 + w, G];
    let a = i as f32 * 0.003;
    let mag = [23.7 * (1.0 - a * a * 0.5), -23.7 * a, -41.0];
    (gyro, accel, mag)
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut p = cortex_m::Peripherals::take().unwrap();
    icount::start(&mut p.SYST);
    let mut out = hio::hstdout().unwrap();

    let nops = ticks(|| (0..10).for_each(|_| ten_thousand_nops()));
    let insn = |t: u32| t as f64 * 100_000.0 / nops as f64 / STEPS as f64;

    let mut sum = 0.0f32;
    let mut euler = Attitude::default();
    let baseline = ticks(|| {
        for i in 0..STEPS {
            let (g, a, _) = sample(i);
            euler.update(black_box(g), black_box(a), 0.0096, 2.0, 0.1);
        }
    });
    sum += euler.yaw;
    let mut ahrs = Ahrs::default();
    let gyro_only = ticks(|| {
        for i in 0..STEPS {
            let (g, a, _) = sample(i);
            ahrs.update(black_box(g), black_box(a), None, 0.05, 0.0096, &GAINS);
        }
    });
    sum += ahrs.euler().yaw;
    let mut ahrs = Ahrs::default();
    let with_mag = ticks(|| {
        for i in 0..STEPS {
            let (g, a, m) = sample(i);
            ahrs.update(black_box(g), black_box(a), Some(black_box(m)), 0.05, 0.0096, &GAINS);
        }
    });
    sum += ahrs.euler().yaw;
    let mut ahrs = Ahrs::default();
    let euler_out = ticks(|| {
        for i in 0..STEPS {
            ahrs.q[3] = black_box(i as f32 * 1e-4);
            let e = ahrs.euler();
            sum += e.yaw + e.roll + e.pitch;
        }
    });
    let mut v = Vertical::default();
    let altitude = ticks(|| {
        for i in 0..STEPS {
            let p = black_box(101_325.0 - i as f32 * 1.2);
            v.update(isa_altitude(p, 101_325.0), 0.04, 1.0);
        }
    });
    sum += v.altitude.unwrap_or(0.0);
    // The parameters as the step reads them: FlashParams' `get` is its RamParams'.
    let store = RamParams::new(DEFAULTS);
    let config = ticks(|| {
        for _ in 0..STEPS {
            let c = Config::read(black_box(&store));
            sum += black_box(c).qnh_pa;
        }
    });
    // The loop overhead alone (the inputs made, nothing estimated).
    let overhead = ticks(|| {
        for i in 0..STEPS {
            let (g, a, m) = sample(i);
            black_box((g, a, m));
        }
    });
    if !sum.is_finite() {
        let _ = writeln!(out, "fusion: non-finite output");
        debug::exit(debug::EXIT_FAILURE);
    }
    let net = |t: u32| insn(t.saturating_sub(overhead));
    let _ = writeln!(
        out,
        "{{\"bench\":\"cortex_m3_imu_fusion\",\"euler_filter_insn\":{:.0},\"ahrs_insn\":{:.0},\
         \"ahrs_mag_insn\":{:.0},\"ahrs_euler_out_insn\":{:.0},\"baro_insn\":{:.0},\
         \"config_read_insn\":{:.0}}}",
        net(baseline),
        net(gyro_only),
        net(with_mag),
        insn(euler_out),
        insn(altitude),
        insn(config)
    );
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}
