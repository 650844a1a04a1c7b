//! The LSM6DSO driver (r2p-drivers) against the emulator's I2C and SPI models and LSM6DSO
//! register model, fed by the world's IMU model on the Triskar2 base.

use std::cell::RefCell;
use std::fmt::Debug;
use std::rc::Rc;

use embedded_hal::i2c::I2c;
use embedded_hal::spi::{Operation, SpiDevice};
use r2p_drivers::lsm6dso::{
    Address, Config, Error, GyroScale, Lsm6dso, Odr, RawSample, RegisterBus,
};
use r2p_emu::periph::i2c::{I2cError, SimI2c};
use r2p_emu::periph::lsm6dso::Lsm6dsoModel;
use r2p_emu::periph::spi::SimSpi;
use r2p_emu::periph::{shared, RegisterDevice, Shared};
use r2p_world::imu::{Imu, ImuParams, ImuReading};
use r2p_world::{Pose, Robot, World};

const ADDR: u8 = 0x6A;
/// The IMU 0.1 m ahead of the base centre, axes aligned with the base.
const MOUNT: Pose = Pose::new(0.1, 0.0, 0.0);

fn triskar() -> World {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/triskar2.toml");
    World::from_robot(&Robot::load(path).unwrap())
}

/// The world, the world's IMU model and the register model it feeds, stepped every 1 ms.
struct Rig {
    world: World,
    imu: Imu,
    dev: Shared<Lsm6dsoModel>,
}

impl Rig {
    fn new(seed: u64) -> Self {
        Rig {
            world: triskar(),
            imu: Imu::new(ImuParams::LSM6DSO, MOUNT, seed, 500),
            dev: shared(Lsm6dsoModel::new()),
        }
    }

    fn spin(&mut self, duty: f64) {
        for b in ["motor1", "motor2", "motor3"] {
            self.world.set_output(b, "DRV_EN", true).unwrap();
            self.world.set_pwm(b, "PWM_AH", (1.0 + duty) / 2.0).unwrap();
            self.world.set_pwm(b, "PWM_BH", (1.0 - duty) / 2.0).unwrap();
        }
    }

    fn step_ms(&mut self) {
        let t = self.world.time_ns() + 1_000_000;
        self.world.advance_to_ns(t);
        self.dev.borrow_mut().advance_to(t, &mut self.imu, &self.world);
    }

    fn i2c(&self) -> SimI2c {
        let mut bus = SimI2c::new();
        bus.attach(ADDR, self.dev.clone());
        bus
    }

    fn spi(&self) -> SimSpi {
        SimSpi::new(self.dev.clone())
    }
}

/// Spins the Triskar2 in place (3 s to steady state at 4.107 rad/s), then reads the IMU for
/// 1 s whenever it flags new gyro data. Returns (samples, expected noise-free reading, ω).
fn spin_and_read<B: RegisterBus>(
    rig: &mut Rig,
    imu: &mut Lsm6dso<B>,
) -> (Vec<[f32; 6]>, ImuReading, f64)
where
    B::Error: Debug,
{
    imu.init(Config::default()).unwrap();
    rig.spin(0.4);
    for _ in 0..3000 {
        rig.step_ms();
    }
    let mut samples = Vec::new();
    for _ in 0..1000 {
        rig.step_ms();
        if imu.data_ready().unwrap().gyro {
            let s = imu.read().unwrap();
            samples.push([s.gyro[0], s.gyro[1], s.gyro[2], s.accel[0], s.accel[1], s.accel[2]]);
        }
    }
    let expected = rig.imu.expected(&rig.world.twist(), &rig.world.twist_rate());
    (samples, expected, rig.world.twist().wz)
}

fn check_spin(samples: &[[f32; 6]], e: &ImuReading, wz: f64) {
    // 104 Hz for 1 s.
    assert!((103..=105).contains(&samples.len()), "{} samples", samples.len());
    let n = samples.len() as f64;
    let mean = |k: usize| samples.iter().map(|s| f64::from(s[k])).sum::<f64>() / n;
    let p = ImuParams::LSM6DSO;
    // Means within 5 standard errors of the device's own noise-free reading, plus half an LSB
    // of rounding (±500 dps: 17.5 mdps; ±4 g: 0.122 mg) and f32 conversion.
    let g_lsb = 17.5e-3f64.to_radians();
    let a_lsb = 0.122e-3 * 9.806_65;
    let g_tol = 5.0 * p.gyro_sigma(104.0) / n.sqrt() + g_lsb / 2.0 + 1e-5;
    let a_tol = 5.0 * p.accel_sigma(104.0) / n.sqrt() + a_lsb / 2.0 + 1e-4;
    assert!((mean(2) - e.gyro[2]).abs() < g_tol, "yaw rate {} vs {}", mean(2), e.gyro[2]);
    for k in 0..3 {
        assert!(
            (mean(3 + k) - e.accel[k]).abs() < a_tol,
            "accel {k}: {} vs {}",
            mean(3 + k),
            e.accel[k]
        );
    }
    // And the truth within the datasheet's offset and sensitivity bounds: ω = 4.107 rad/s,
    // centripetal −ω²·0.1 m = −1.69 m/s² on x, +1 g on z.
    assert!((wz - 4.107).abs() < 0.001, "{wz}");
    assert!((mean(2) - wz).abs() < 0.01 * wz + 1f64.to_radians() + g_tol, "{} vs {wz}", mean(2));
    let ax = -wz * wz * 0.1;
    assert!((mean(3) - ax).abs() < 0.01 * ax.abs() + 0.020 * 9.81 + a_tol, "{} vs {ax}", mean(3));
    assert!((mean(5) - 9.806_65).abs() < 0.01 * 9.81 + 0.020 * 9.81 + a_tol, "{}", mean(5));
    // Each sample within 5σ of the expected value (and one LSB).
    for s in samples {
        assert!((f64::from(s[2]) - e.gyro[2]).abs() < 5.0 * p.gyro_sigma(104.0) + g_lsb, "{s:?}");
    }
}

#[test]
fn turning_robot_reads_its_yaw_rate_over_i2c() {
    let mut rig = Rig::new(1);
    let mut imu = Lsm6dso::new_i2c(rig.i2c(), Address::Sa0Low);
    let (samples, e, wz) = spin_and_read(&mut rig, &mut imu);
    check_spin(&samples, &e, wz);
}

#[test]
fn turning_robot_reads_its_yaw_rate_over_spi() {
    let mut rig = Rig::new(1);
    let mut imu = Lsm6dso::new_spi(rig.spi());
    let (samples, e, wz) = spin_and_read(&mut rig, &mut imu);
    check_spin(&samples, &e, wz);
}

#[test]
fn same_seed_same_readings_other_seed_other_noise() {
    let run = |seed| {
        let mut rig = Rig::new(seed);
        let mut imu = Lsm6dso::new_i2c(rig.i2c(), Address::Sa0Low);
        imu.init(Config::default()).unwrap();
        rig.spin(0.3);
        let mut raw: Vec<RawSample> = Vec::new();
        for _ in 0..300 {
            rig.step_ms();
            if imu.data_ready().unwrap().gyro {
                raw.push(imu.read_raw().unwrap());
            }
        }
        raw
    };
    let a = run(3);
    assert_eq!(a.len(), 31); // 300 ms at 104 Hz
    assert_eq!(a, run(3));
    assert_ne!(a, run(4));
}

#[test]
fn absent_address_is_nacked_and_the_error_propagates() {
    let rig = Rig::new(1);
    let mut bus = rig.i2c();
    let e = Lsm6dso::new_i2c(&mut bus, Address::Sa0High).init(Config::default()).unwrap_err();
    assert_eq!(e, Error::Bus(I2cError::NoDevice { address: 0x6B }));
    assert!(e.to_string().contains("NoDevice"), "{e}");
    let text = I2cError::NoDevice { address: 0x6B }.to_string();
    assert_eq!(text, "no I2C device acknowledged address 0x6b");
    assert_eq!(bus.nacks(), 1, "the driver stops at the first failure");
    assert_eq!(
        embedded_hal::i2c::Error::kind(&I2cError::NoDevice { address: 0x6B }),
        embedded_hal::i2c::ErrorKind::NoAcknowledge(
            embedded_hal::i2c::NoAcknowledgeSource::Address
        )
    );
}

/// Another chip on the bus: an LSM6DS3 (WHO_AM_I 0x69).
struct OtherChip;
impl RegisterDevice for OtherChip {
    fn read_register(&mut self, reg: u8) -> u8 {
        if reg == 0x0F {
            0x69
        } else {
            0
        }
    }
    fn write_register(&mut self, _: u8, _: u8) {}
    fn next_register(&self, reg: u8) -> u8 {
        reg + 1
    }
}

#[test]
fn wrong_chip_or_no_chip_names_the_value_read() {
    let mut bus = SimI2c::new();
    bus.attach(0x6B, Rc::new(RefCell::new(OtherChip)));
    let e = Lsm6dso::new_i2c(&mut bus, Address::Sa0High).probe().unwrap_err();
    assert_eq!(e, Error::WrongDevice { part: "LSM6DSO", found: 0x69, expected: 0x6C });
    // SPI with nothing behind the chip select: MISO floats high.
    let e = Lsm6dso::new_spi(SimSpi::unconnected()).probe().unwrap_err();
    assert_eq!(e, Error::WrongDevice { part: "LSM6DSO", found: 0xFF, expected: 0x6C });
    assert!(e.to_string().contains("read 0xff, expected 0x6c"), "{e}");
}

#[test]
fn i2c_register_pointer_and_auto_increment() {
    let rig = Rig::new(1);
    let mut bus = rig.i2c();
    // Write CTRL1_XL and CTRL2_G in one transaction (pointer, then two data bytes).
    bus.write(ADDR, &[0x10, 0x48, 0x44]).unwrap();
    let mut b = [0; 4];
    bus.write_read(ADDR, &[0x0F], &mut b).unwrap();
    assert_eq!(b, [0x6C, 0x48, 0x44, 0x04], "WHO_AM_I, CTRL1_XL, CTRL2_G, CTRL3_C");
    // A read with no pointer goes on from where the last one stopped.
    let mut c = [0; 1];
    bus.read(ADDR, &mut c).unwrap();
    assert_eq!(c, [rig.dev.borrow().peek(0x13)]);
    // IF_INC off: a burst reads the same register again and again.
    bus.write(ADDR, &[0x12, 0x00]).unwrap();
    bus.write_read(ADDR, &[0x0F], &mut b).unwrap();
    assert_eq!(b, [0x6C; 4]);
    // WHO_AM_I is read-only.
    bus.write(ADDR, &[0x0F, 0x00]).unwrap();
    bus.write_read(ADDR, &[0x0F], &mut c).unwrap();
    assert_eq!(c, [0x6C]);
}

#[test]
fn spi_read_bit_selects_read_or_write() {
    let rig = Rig::new(1);
    let mut spi = rig.spi();
    spi.write(&[0x10, 0x5C]).unwrap(); // bit 7 clear: write CTRL1_XL
    assert_eq!(rig.dev.borrow().peek(0x10), 0x5C);
    let mut b = [0; 2];
    spi.transaction(&mut [Operation::Write(&[0x80 | 0x0F]), Operation::Read(&mut b)]).unwrap();
    assert_eq!(b, [0x6C, 0x5C]);
    // Full duplex: the command byte's MISO is idle, data follow.
    let mut buf = [0x90, 0xAA, 0xAA];
    spi.transfer_in_place(&mut buf).unwrap();
    assert_eq!(buf, [0x00, 0x5C, 0x00]);
    assert_eq!(rig.dev.borrow().peek(0x10), 0x5C, "a read does not write");
}

#[test]
fn data_ready_flags_clear_on_read_and_outputs_saturate() {
    let rig = Rig::new(1);
    let mut imu = Lsm6dso::new_spi(rig.spi());
    let config = Config { gyro_scale: GyroScale::Dps125, gyro_odr: Odr::Hz52, ..Config::default() };
    imu.init(config).unwrap();
    let r = ImuReading { gyro: [0.0, 0.0, 4.0], accel: [0.0, 0.0, 9.80665], temperature_c: 35.0 };
    rig.dev.borrow_mut().latch(&r, true, true);
    let d = imu.data_ready().unwrap();
    assert!(d.accel && d.gyro && d.temp);
    let s = imu.read().unwrap();
    assert!(!imu.data_ready().unwrap().gyro, "reading the outputs clears GDA");
    // 4 rad/s = 229 dps > 125 dps: the output saturates at 32767 × 4.375 mdps = 143.4 dps.
    assert_eq!(imu.read_raw().unwrap().gyro[2], i16::MAX);
    assert!((f64::from(s.gyro[2]).to_degrees() - 143.35).abs() < 0.01, "{:?}", s.gyro);
    assert!((s.accel[2] - 9.80665).abs() < 2e-3);
    assert_eq!(s.temp_c, 35.0);
    // Software reset restores the power-up registers.
    let mut spi = rig.spi();
    spi.write(&[0x12, 0x01]).unwrap();
    assert_eq!(rig.dev.borrow().peek(0x10), 0x00);
    assert_eq!(rig.dev.borrow().peek(0x12), 0x04);
}

/// On SPI the ST parts of the IMU board that can turn their I2C interface off do (a part whose
/// chip select is high while another is addressed is in I2C mode and reads SCK and MOSI as
/// SCL and SDA); the LIS3MDL has no such bit (DS9463 Table 25: CTRL_REG3's bit 7 must be 0,
/// and the model does not store it); on I2C every interface stays on.
#[test]
fn on_spi_each_st_part_that_can_turns_its_i2c_interface_off() {
    use r2p_drivers::lps22::Chip;
    use r2p_drivers::{lis3mdl, lps22};
    use r2p_emu::periph::lis3mdl::Lis3mdlModel;
    use r2p_emu::periph::lps22::Lps22Model;
    let imu = shared(Lsm6dsoModel::new());
    let mag = shared(Lis3mdlModel::new());
    let (hh, df) = (shared(Lps22Model::new(Chip::Hh)), shared(Lps22Model::new(Chip::Df)));
    Lsm6dso::new_spi(SimSpi::new(imu.clone())).init(Config::default()).unwrap();
    lis3mdl::Lis3mdl::new_spi(SimSpi::new(mag.clone())).init(lis3mdl::Config::default()).unwrap();
    for baro in [&hh, &df] {
        lps22::Lps22::new_spi(SimSpi::new(baro.clone())).init(lps22::Config::default()).unwrap();
    }
    assert_eq!(imu.borrow().peek(0x13), 0x04, "LSM6DSO CTRL4_C: I2C_disable");
    assert_eq!(mag.borrow().peek(0x22), 0x00, "LIS3MDL CTRL_REG3: continuous, nothing else");
    assert_eq!(hh.borrow().peek(0x0E), 0x03, "LPS22HH IF_CTRL: I2C_DISABLE, I3C_DISABLE");
    assert_eq!(df.borrow().peek(0x0E), 0x40, "LPS22DF IF_CTRL: I2C_I3C_DIS");

    let (imu, mag, baro) = (
        shared(Lsm6dsoModel::new()),
        shared(Lis3mdlModel::new()),
        shared(Lps22Model::new(Chip::Hh)),
    );
    let on = |address: u8, device: Shared<dyn RegisterDevice>| {
        let mut bus = SimI2c::new();
        bus.attach(address, device);
        bus
    };
    Lsm6dso::new_i2c(on(ADDR, imu.clone()), Address::Sa0Low).init(Config::default()).unwrap();
    lis3mdl::Lis3mdl::new_i2c(on(0x1E, mag.clone()), lis3mdl::Address::Sa1High)
        .init(lis3mdl::Config::default())
        .unwrap();
    lps22::Lps22::new_i2c(on(0x5C, baro.clone()), lps22::Address::Sa0Low)
        .init(lps22::Config::default())
        .unwrap();
    assert_eq!(
        (imu.borrow().peek(0x13), mag.borrow().peek(0x22), baro.borrow().peek(0x0E)),
        (0, 0, 0)
    );
}
