//! R2P messages as the standard ROS 2 messages they stand for, in CDR: Odometry →
//! nav_msgs/Odometry, Battery → sensor_msgs/BatteryState, one Proximity channel →
//! sensor_msgs/Range, Imu → sensor_msgs/Imu, MagneticField → sensor_msgs/MagneticField,
//! Barometer → sensor_msgs/FluidPressure, GnssFix → sensor_msgs/NavSatFix; geometry_msgs/Twist
//! → Twist2D.
//!
//! Conventions (REP 103, REP 105, REP 117): metres, radians, SI; the odometry in frame `odom`
//! for child `base_link`, yaw as a quaternion about z; BatteryState's current negative while
//! discharging (R2P's is positive drawn); a range too near is -inf, too far +inf.

use r2p_module::trig::sin_cos;
use r2p_msgs::{Barometer, Battery, GnssFix, Imu, MagneticField, Odometry, Proximity, Twist2D};

use crate::cdr::{CdrReader, CdrWriter};
use crate::codec::{Malformed, Overflow};

/// A ROS 2 time: seconds and nanoseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stamp {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, < 1e9.
    pub nanosec: u32,
}

impl Stamp {
    /// From nanoseconds since the epoch of the clock the gateway stamps with.
    pub fn from_ns(ns: i64) -> Self {
        Self {
            sec: ns.div_euclid(1_000_000_000) as i32,
            nanosec: ns.rem_euclid(1_000_000_000) as u32,
        }
    }
}

fn header(w: &mut CdrWriter<'_>, stamp: Stamp, frame_id: &str) {
    w.i32(stamp.sec);
    w.u32(stamp.nanosec);
    w.string(frame_id);
}

/// A quaternion (x, y, z, w) from roll, pitch, yaw (ZYX).
fn quaternion(roll: f32, pitch: f32, yaw: f32) -> [f64; 4] {
    let (sr, cr) = sin_cos(roll * 0.5);
    let (sp, cp) = sin_cos(pitch * 0.5);
    let (sy, cy) = sin_cos(yaw * 0.5);
    [
        f64::from(sr * cp * cy - cr * sp * sy),
        f64::from(cr * sp * cy + sr * cp * sy),
        f64::from(cr * cp * sy - sr * sp * cy),
        f64::from(cr * cp * cy + sr * sp * sy),
    ]
}

/// nav_msgs/msg/Odometry: pose in `odom`, twist in `base_link`; covariances unknown (zeros).
pub fn odometry(o: &Odometry, stamp: Stamp, out: &mut [u8]) -> Result<usize, Overflow> {
    let mut w = CdrWriter::new(out);
    header(&mut w, stamp, "odom");
    w.string("base_link");
    for v in [f64::from(o.x), f64::from(o.y), 0.0] {
        w.f64(v);
    }
    for v in quaternion(0.0, 0.0, o.theta) {
        w.f64(v);
    }
    w.zeros_f64(36);
    for v in [f64::from(o.vx), f64::from(o.vy), 0.0, 0.0, 0.0, f64::from(o.wz)] {
        w.f64(v);
    }
    w.zeros_f64(36);
    w.finish()
}

/// sensor_msgs/msg/BatteryState: voltage and current measured, the rest unknown (NaN), status
/// from the current's sign, present.
pub fn battery_state(b: &Battery, stamp: Stamp, out: &mut [u8]) -> Result<usize, Overflow> {
    const DISCHARGING: u8 = 2;
    const CHARGING: u8 = 1;
    const HEALTH_UNKNOWN: u8 = 0;
    const TECHNOLOGY_LION: u8 = 2;
    let mut w = CdrWriter::new(out);
    header(&mut w, stamp, "battery");
    w.f32(b.voltage);
    w.f32(f32::NAN); // temperature
    w.f32(-b.current);
    for _ in 0..4 {
        w.f32(f32::NAN); // charge, capacity, design capacity, percentage
    }
    w.u8(if b.current < 0.0 { CHARGING } else { DISCHARGING });
    w.u8(HEALTH_UNKNOWN);
    w.u8(TECHNOLOGY_LION);
    w.u8(1); // present
    w.u32(0); // cell_voltage: none
    w.u32(0); // cell_temperature: none
    w.string("");
    w.string("");
    w.finish()
}

/// The proximity module's rangers: infrared, 0.04–3 m (docs in apps/proximity).
#[derive(Clone, Copy, Debug)]
pub struct RangerSpec {
    /// sensor_msgs/Range's radiation type: 0 ultrasound, 1 infrared.
    pub radiation_type: u8,
    /// rad.
    pub field_of_view: f32,
    /// m.
    pub min_range: f32,
    /// m.
    pub max_range: f32,
}

/// sensor_msgs/msg/Range for one proximity channel, in frame `frame_id`.
pub fn range(
    p: &Proximity,
    channel: usize,
    spec: &RangerSpec,
    frame_id: &str,
    stamp: Stamp,
    out: &mut [u8],
) -> Result<usize, Overflow> {
    let Some(&d) = p.distance.get(channel) else { return Err(Overflow) };
    let value = match p.status[channel] {
        0 => d,
        1 => f32::NEG_INFINITY,
        2 => f32::INFINITY,
        _ => f32::NAN,
    };
    let mut w = CdrWriter::new(out);
    header(&mut w, stamp, frame_id);
    w.u8(spec.radiation_type);
    w.f32(spec.field_of_view);
    w.f32(spec.min_range);
    w.f32(spec.max_range);
    w.f32(value);
    w.f32(0.0); // variance unknown
    w.finish()
}

/// sensor_msgs/msg/Imu in frame `imu_link`: the filter's attitude, the rate, the specific force;
/// covariances unknown (zeros), or the orientation's first element -1 while the module has no
/// attitude yet (REP 145: "no orientation estimate").
pub fn imu(m: &Imu, stamp: Stamp, out: &mut [u8]) -> Result<usize, Overflow> {
    let mut w = CdrWriter::new(out);
    header(&mut w, stamp, "imu_link");
    for v in quaternion(m.roll, m.pitch, m.yaw) {
        w.f64(v);
    }
    w.f64(if m.status == 0 { 0.0 } else { -1.0 });
    w.zeros_f64(8);
    for v in m.rate {
        w.f64(f64::from(v));
    }
    w.zeros_f64(9);
    for v in m.accel {
        w.f64(f64::from(v));
    }
    w.zeros_f64(9);
    w.finish()
}

/// sensor_msgs/msg/MagneticField in frame `imu_link`: the calibrated field in tesla (R2P's is in
/// µT); covariance unknown (zeros, REP 145).
pub fn magnetic_field(m: &MagneticField, stamp: Stamp, out: &mut [u8]) -> Result<usize, Overflow> {
    let mut w = CdrWriter::new(out);
    header(&mut w, stamp, "imu_link");
    for v in m.field {
        w.f64(f64::from(v) * 1e-6);
    }
    w.zeros_f64(9);
    w.finish()
}

/// sensor_msgs/msg/FluidPressure in frame `imu_link`: pascals; variance unknown (0).
pub fn fluid_pressure(b: &Barometer, stamp: Stamp, out: &mut [u8]) -> Result<usize, Overflow> {
    let mut w = CdrWriter::new(out);
    header(&mut w, stamp, "imu_link");
    w.f64(f64::from(b.pressure));
    w.f64(0.0);
    w.finish()
}

/// NavSatStatus's `status` for no fix (its STATUS_NO_FIX).
pub const NAV_SAT_NO_FIX: i8 = -1;
/// NavSatStatus's `service`: GPS (SERVICE_GPS; a u-blox receiver tracks more, NAV-PVT does not
/// say which constellations the solution used).
pub const NAV_SAT_SERVICE_GPS: u16 = 1;

/// sensor_msgs/msg/NavSatFix in frame `gnss`: status STATUS_FIX (0) for a 2-D or 3-D fix (with
/// or without dead reckoning), else STATUS_NO_FIX; height above the WGS-84 ellipsoid, as ROS
/// defines it; the receiver's accuracy estimates as a diagonal covariance
/// (COVARIANCE_TYPE_DIAGONAL_KNOWN).
pub fn nav_sat_fix(g: &GnssFix, stamp: Stamp, out: &mut [u8]) -> Result<usize, Overflow> {
    let mut w = CdrWriter::new(out);
    header(&mut w, stamp, "gnss");
    let fix = matches!(g.fix_type, 2..=4) && g.status == 0;
    w.u8(if fix { 0 } else { NAV_SAT_NO_FIX as u8 });
    w.prim(&NAV_SAT_SERVICE_GPS.to_le_bytes());
    w.f64(f64::from(g.latitude) * 1e-7);
    w.f64(f64::from(g.longitude) * 1e-7);
    w.f64(f64::from(g.altitude));
    let (h, v) = (f64::from(g.h_acc), f64::from(g.v_acc));
    for c in [h * h, 0.0, 0.0, 0.0, h * h, 0.0, 0.0, 0.0, v * v] {
        w.f64(c);
    }
    w.u8(2);
    w.finish()
}

/// geometry_msgs/msg/Twist as the base's planar velocity command (linear x, y; angular z; the
/// rest ignored). Non-finite values are refused.
pub fn twist(cdr: &[u8]) -> Result<Twist2D, Malformed> {
    let mut r = CdrReader::new(cdr)?;
    let mut v = [0f64; 6];
    for x in &mut v {
        *x = r.f64()?;
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(Malformed);
    }
    Ok(Twist2D { vx: v[0] as f32, vy: v[1] as f32, wz: v[5] as f32 })
}

/// CDR sizes of the mapped messages (with the header and frame ids the gateway uses).
pub mod size {
    /// nav_msgs/Odometry: header `odom`, child `base_link`.
    pub const ODOMETRY: usize = 4 + 8 + 4 + 5 + 3 + 4 + 10 + 6 + 7 * 8 + 36 * 8 + 6 * 8 + 36 * 8;
    /// Buffer large enough for any mapped message.
    pub const MAX: usize = 760;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odometry_is_724_bytes_with_the_pose_where_ros_reads_it() {
        let o = Odometry {
            x: 1.5,
            y: -2.0,
            theta: core::f32::consts::FRAC_PI_2,
            vx: 0.3,
            vy: 0.0,
            wz: 0.1,
        };
        let mut buf = [0u8; size::MAX];
        let n = odometry(&o, Stamp { sec: 3, nanosec: 5 }, &mut buf).unwrap();
        assert_eq!(n, size::ODOMETRY);
        // header: sec, nanosec, "odom"; child "base_link"; position at the next 8-byte boundary.
        assert_eq!(&buf[4..12], &[3, 0, 0, 0, 5, 0, 0, 0]);
        assert_eq!(&buf[12..21], &[5, 0, 0, 0, b'o', b'd', b'o', b'm', 0]);
        let pos = 4 + 40;
        assert_eq!(f64::from_le_bytes(buf[pos..pos + 8].try_into().unwrap()), 1.5);
        let qz = f64::from_le_bytes(buf[pos + 40..pos + 48].try_into().unwrap());
        assert!((qz - core::f64::consts::FRAC_1_SQRT_2).abs() < 1e-6, "{qz}");
    }

    #[test]
    fn the_imu_modules_other_readings_in_si_units_where_ros_reads_them() {
        let stamp = Stamp { sec: 7, nanosec: 5 };
        let mut out = [0u8; 400];
        // Header: 4 (encapsulation) + 8 (stamp) + 4 + 9 ("imu_link\0") = 25; the f64s aligned
        // to 8 from the encapsulation's end: at 28.
        let m = MagneticField { field: [20.0, -5.0, -40.0], ..MagneticField::default() };
        let n = magnetic_field(&m, stamp, &mut out).unwrap();
        assert_eq!(n, 28 + 3 * 8 + 9 * 8);
        let f = |o: usize| f64::from_le_bytes(out[o..o + 8].try_into().unwrap());
        let (x, z) = (f(28), f(44));
        assert!((x - 20e-6).abs() < 1e-12 && (z + 40e-6).abs() < 1e-12, "{x} {z}");
        let b = Barometer { pressure: 98_765.5, ..Barometer::default() };
        assert_eq!(fluid_pressure(&b, stamp, &mut out).unwrap(), 28 + 16);
        assert_eq!(f64::from_le_bytes(out[28..36].try_into().unwrap()), 98_765.5);
        // NavSatFix after "gnss\0" (16..21): status int8 at 21, service uint16 at 22, latitude
        // at 28, longitude 36, altitude 44, covariance 52..124, its type at 124.
        let g = GnssFix {
            latitude: 454_780_000,
            longitude: 92_270_000,
            altitude: 170.5,
            h_acc: 2.0,
            v_acc: 3.0,
            fix_type: 3,
            ..GnssFix::default()
        };
        let n = nav_sat_fix(&g, stamp, &mut out).unwrap();
        assert_eq!(n, 125);
        assert_eq!((out[21], u16::from_le_bytes([out[22], out[23]])), (0, 1));
        let f = |o: usize| f64::from_le_bytes(out[o..o + 8].try_into().unwrap());
        assert!((f(28) - 45.478).abs() < 1e-9 && (f(36) - 9.227).abs() < 1e-9, "{}", f(28));
        assert_eq!((f(44), f(52), f(84), f(116), out[124]), (170.5, 4.0, 4.0, 9.0, 2));
        // No fix, or no receiver: STATUS_NO_FIX.
        for g in
            [GnssFix { fix_type: 0, ..g }, GnssFix { status: 2, ..g }, GnssFix { fix_type: 5, ..g }]
        {
            nav_sat_fix(&g, stamp, &mut out).unwrap();
            assert_eq!(out[21] as i8, NAV_SAT_NO_FIX);
        }
    }

    #[test]
    fn twist_reads_linear_xy_and_angular_z() {
        let mut buf = [0u8; 52];
        let mut w = CdrWriter::new(&mut buf);
        for v in [0.5, -0.25, 9.0, 8.0, 7.0, 1.25] {
            w.f64(v);
        }
        let n = w.finish().unwrap();
        assert_eq!(twist(&buf[..n]), Ok(Twist2D { vx: 0.5, vy: -0.25, wz: 1.25 }));
        assert_eq!(twist(&buf[..n - 1]), Err(Malformed));
        buf[4..12].copy_from_slice(&f64::NAN.to_le_bytes());
        assert_eq!(twist(&buf[..n]), Err(Malformed));
    }

    #[test]
    fn ranges_out_of_reach_are_infinities() {
        let p = Proximity {
            distance: [0.5, f32::NAN, f32::NAN, 0.2],
            status: [0, 1, 2, 3],
            supply_fault: false,
        };
        let spec =
            RangerSpec { radiation_type: 1, field_of_view: 0.1, min_range: 0.04, max_range: 3.0 };
        let mut buf = [0u8; 64];
        let mut value = |ch| {
            let n = range(&p, ch, &spec, "range_0", Stamp::default(), &mut buf).unwrap();
            f32::from_le_bytes(buf[n - 8..n - 4].try_into().unwrap())
        };
        assert_eq!(value(0), 0.5);
        assert_eq!(value(1), f32::NEG_INFINITY);
        assert_eq!(value(2), f32::INFINITY);
        assert!(value(3).is_nan());
        assert!(range(&p, 4, &spec, "x", Stamp::default(), &mut buf).is_err());
    }
}
