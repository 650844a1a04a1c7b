//! The IMU board's sensor rig (issue 21): what the module's MCU finds on its pins
//! (firmware/boards/imu.toml), register- and byte-exact, fed by the world's devices of the
//! board ([`r2p_world::imu_module`]).
//!
//! - **SPI1**, two parts on their own chip selects: the LSM6DSO (`IMU_CS`, [`Lsm6dsoModel`])
//!   and the LPS22HH (`BARO_CS`, [`Lps22Model`]; the board's barometer, [`BARO_CHIP`]).
//! - **SPI2**, the LIS3MDL alone (`MAG_CS`, [`Lis3mdlModel`]): it has no I2C-disable bit, so
//!   the board gives it a bus of its own where no other part's traffic can reach its I2C
//!   interface (hardware/imu/README.md).
//!
//! Each part is behind its own [`SimSpi`] handle ([`ImuSensors::lsm6dso_spi`] …) for the
//! `r2p-drivers` driver the firmware owns. The chip selects are separate, so a transaction to
//! one part never reaches another, as on the board (the I2C side a deselected part keeps
//! listening with is not modelled: on the board no part that has it enabled shares a bus).
//! - **USART1**, an external u-blox receiver ([`UbxGnssModel`]) on the paced UART
//!   ([`ImuSensors::gnss_uart`]: the bytes the firmware reads at its USART's rate, and writes
//!   to configure the receiver), and its time pulse on TIM3_CH4 ([`ImuSensors::take_pps_us`]:
//!   the edges the input capture would take, in µs since boot). By default the receiver starts
//!   from its factory settings ([`GnssSetup::Factory`]: NMEA at 1 Hz at its default baud rate),
//!   as a receiver bought and plugged in does: the firmware configures it at boot
//!   (`r2p_drivers::ubx::boot_config`), and again whenever it comes back.
//!
//! [`ImuSensors::advance`] runs every emulator step (1 ms): it follows the world's plugs, runs
//! the samples each part has due at its configured rate from the world at that moment
//! ([`World::sample_imu`], [`World::sample_magnetometer`], [`World::sample_pressure`]), sends
//! the receiver's epochs due from the antenna's place ([`World::gnss_antenna`]) and moves the
//! line. Nothing here corrects what the parts get wrong: offsets, noise, iron and the
//! receiver's error reach the firmware as the world makes them.
//!
//! **Boot.** A board boot is a power cycle, the receiver's too (the board's connector powers
//! it): the three parts start from their power-up registers, their clocks at the boot instant
//! (no sample before the firmware configures them), and the receiver from its power-up
//! settings. The receiver model takes its copy of the world's receiver (`ImuModule::gnss`:
//! the same device and error stream) and starts cold at the boot (`UbxGnssModel::powered_at`:
//! no backup supply on the port): its time to first fix counts from then, and its time pulse
//! starts with its fix.
//!
//! **Unplugging** (`World::set_imu_sensor_connected`, or `unplugged = [...]` in the robot
//! file): an SPI part off its bus reads 0xFF on every byte (MISO floats high) and takes no
//! writes; plugged again, it restarts from its power-up registers and the firmware must
//! configure it again. The receiver unplugged sends nothing, hears nothing and its PPS stops;
//! plugged again, it powers up as at boot (factory settings, or its stored ones), cold: its
//! epochs come from the next second, its fix and pulse a time to first fix later (a frame
//! already on the wire when the cable comes off is not cut short).

use std::collections::VecDeque;

use r2p_world::imu_module::ImuSensor;
use r2p_world::World;
use rtcan::Micros;

use crate::periph::lis3mdl::{Lis3mdlModel, MagInput};
use crate::periph::lps22::{BaroInput, Lps22Model};
use crate::periph::lsm6dso::Lsm6dsoModel;
use crate::periph::spi::{Plug, SimSpi};
use crate::periph::uart::SimUart;
pub use crate::periph::ubx_gnss::Generation;
use crate::periph::ubx_gnss::UbxGnssModel;
use crate::periph::{shared, Shared};
use r2p_drivers::lps22::Chip;

/// Unix time of 1980-01-06 00:00:00 UTC, the start of GPS time.
const GPS_EPOCH_UNIX_S: u64 = 315_964_800;
/// GPS time ahead of UTC since 2017-01-01, s (IERS Bulletin C: no leap second since).
const GPS_UTC_LEAP_S: u64 = 18;
const SECONDS_PER_WEEK: u64 = 604_800;

/// The board's barometer: the LPS22HH (hardware/imu, U103; the LPS22DF it was drawn for has no
/// LCSC number). The firmware's driver runs either.
pub const BARO_CHIP: Chip = Chip::Hh;
/// PPS edges kept for the firmware: a timer capture holds one (older ones overwritten, its
/// overcapture flag set); a few let a step that took several seconds lose none.
const PPS_KEPT: usize = 8;

/// What the receiver runs when it powers up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GnssSetup {
    /// Its factory settings ([`UbxGnssModel::factory`]): NMEA at 1 Hz at the generation's
    /// default baud rate, until the firmware configures it (in RAM: lost at power-down).
    Factory(Generation),
    /// Configured in its flash ([`UbxGnssModel::new`]): NAV-PVT alone at `rate_hz` (1–10), at
    /// the MCU's baud rate.
    Configured {
        /// Navigation rate, Hz.
        rate_hz: u32,
    },
}

/// How the external receiver is set up and connected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GnssLink {
    /// What the receiver runs at power-up.
    pub receiver: GnssSetup,
    /// The MCU's USART1 rate at boot, baud (8N1; the firmware changes it through
    /// [`SimUart::set_baud`]).
    pub mcu_baud: u32,
    /// The MCU's receive buffer, bytes (its DMA ring buffer; 1 = the bare data register).
    pub rx_buffer: usize,
    /// UTC at the world's time 0, Unix seconds (a whole second).
    pub start_unix_s: u64,
}

impl GnssLink {
    /// An M10 from the factory (NMEA at 38 400 baud), the MCU's USART1 at the rate
    /// `r2p_drivers::ubx` runs the link at (38 400), a 256-byte ring buffer, the world starting
    /// 2026-11-27 12:00:00 UTC.
    pub const DEFAULT: GnssLink = GnssLink {
        receiver: GnssSetup::Factory(Generation::M10),
        mcu_baud: r2p_drivers::ubx::OPERATING_BAUD,
        rx_buffer: 256,
        start_unix_s: 1_795_780_800,
    };

    /// GPS time of week at the world's time 0, ms.
    pub fn start_tow_ms(&self) -> u32 {
        let gps_s = self.start_unix_s - GPS_EPOCH_UNIX_S + GPS_UTC_LEAP_S;
        ((gps_s % SECONDS_PER_WEEK) * 1000) as u32
    }
}

impl Default for GnssLink {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The sensors on one IMU board and its GNSS port. See the module documentation.
pub struct ImuSensors {
    name: String,
    boot_us: Micros,
    lsm6dso: Shared<Lsm6dsoModel>,
    lis3mdl: Shared<Lis3mdlModel>,
    lps22hh: Shared<Lps22Model>,
    /// The SPI parts' plugs, in [`SPI_PARTS`]'s order.
    plugs: [Plug; 3],
    gnss: UbxGnssModel,
    gnss_plugged: bool,
    link: GnssLink,
    uart: SimUart,
    pps_us: VecDeque<Micros>,
    pps_seen_ns: u64,
}

/// The receiver of IMU board `name` powered up at `now_ns` as `link` says: cold.
fn power_up_receiver(world: &World, name: &str, link: &GnssLink, now_ns: u64) -> UbxGnssModel {
    let receiver = world.imu_module(name).unwrap_or_else(|e| bug(e)).gnss.clone();
    let (start, tow) = (link.start_unix_s, link.start_tow_ms());
    let gnss = match link.receiver {
        GnssSetup::Factory(generation) => UbxGnssModel::factory(receiver, generation, start, tow),
        GnssSetup::Configured { rate_hz } => UbxGnssModel::new(receiver, rate_hz, start, tow),
    };
    gnss.powered_at(now_ns)
}

/// A board that asks the world for what its own rig has: a bug of this layer.
fn bug(e: r2p_world::IoError) -> ! {
    panic!("{e}")
}

/// The SPI parts (SPI1's two and SPI2's LIS3MDL), in the order of [`ImuSensors`]' plugs.
const SPI_PARTS: [ImuSensor; 3] =
    [ImuSensor::AccelGyro, ImuSensor::Magnetometer, ImuSensor::Barometer];

impl ImuSensors {
    /// The rig of IMU board `name` of `world`, powered up at `boot_us` (virtual time, µs),
    /// its receiver on `link`. An error if `world` has no IMU board of that name.
    pub fn new(world: &World, name: &str, boot_us: Micros, link: GnssLink) -> Result<Self, String> {
        let module = world.imu_module(name).map_err(|e| e.to_string())?;
        let boot_ns = boot_us * 1000;
        let plugs = SPI_PARTS.map(|s| Plug::new(module.connected(s)));
        let gnss = power_up_receiver(world, name, &link, boot_ns);
        let mut uart = SimUart::new(link.mcu_baud, link.rx_buffer);
        uart.advance_to(boot_ns);
        let mut rig = Self {
            name: name.to_string(),
            boot_us,
            lsm6dso: shared(Lsm6dsoModel::new()),
            lis3mdl: shared(Lis3mdlModel::new()),
            lps22hh: shared(Lps22Model::new(BARO_CHIP)),
            plugs,
            gnss,
            gnss_plugged: module.connected(ImuSensor::Gnss),
            link,
            uart,
            pps_us: VecDeque::new(),
            pps_seen_ns: boot_ns,
        };
        for part in SPI_PARTS {
            rig.power_up(part, boot_ns);
        }
        Ok(rig)
    }

    /// Puts `part`'s register model in its power-up state with its clock at `now_ns` (its
    /// sensors are powered down then: no sample falls due).
    fn power_up(&mut self, part: ImuSensor, now_ns: u64) {
        match part {
            ImuSensor::AccelGyro => {
                let mut m = self.lsm6dso.borrow_mut();
                *m = Lsm6dsoModel::new();
                m.advance_with(now_ns, |_| unreachable!("powered down at power-up"));
            }
            ImuSensor::Magnetometer => {
                let mut m = self.lis3mdl.borrow_mut();
                *m = Lis3mdlModel::new();
                m.advance_with(now_ns, || unreachable!("powered down at power-up"));
            }
            ImuSensor::Barometer => {
                let mut m = self.lps22hh.borrow_mut();
                *m = Lps22Model::new(BARO_CHIP);
                m.advance_with(now_ns, || unreachable!("powered down at power-up"));
            }
            ImuSensor::Gnss => {}
        }
    }

    /// Moves the rig to `now_us` (virtual time, µs; calls in time order, every step): follows
    /// the world's plugs, latches the samples due in each plugged part from the world now,
    /// sends the receiver's epochs due and moves its line, records its PPS edges.
    pub fn advance(&mut self, now_us: Micros, world: &mut World) {
        let now_ns = now_us * 1000;
        let plugged = |s| world.imu_sensor_connected(&self.name, s).unwrap_or_else(|e| bug(e));
        let states = SPI_PARTS.map(plugged);
        let gnss_plugged = plugged(ImuSensor::Gnss);
        if gnss_plugged && !self.gnss_plugged {
            self.gnss = power_up_receiver(world, &self.name, &self.link, now_ns);
        }
        self.gnss_plugged = gnss_plugged;
        for (k, part) in SPI_PARTS.into_iter().enumerate() {
            if states[k] && !self.plugs[k].plugged() {
                self.power_up(part, now_ns);
            }
            self.plugs[k].set(states[k]);
        }
        let name = self.name.as_str();
        if self.plugs[0].plugged() {
            self.lsm6dso.borrow_mut().advance_with(now_ns, |odr_hz| {
                world.sample_imu(name, odr_hz).unwrap_or_else(|e| bug(e))
            });
        }
        if self.plugs[1].plugged() {
            self.lis3mdl.borrow_mut().advance_with(now_ns, || {
                let s = world.sample_magnetometer(name).unwrap_or_else(|e| bug(e));
                MagInput { field_ut: s.field_ut, temperature_c: s.temperature_c }
            });
        }
        if self.plugs[2].plugged() {
            self.lps22hh.borrow_mut().advance_with(now_ns, || {
                let s = world.sample_pressure(name).unwrap_or_else(|e| bug(e));
                BaroInput { pressure_pa: s.pressure_pa, temperature_c: s.temperature_c }
            });
        }
        let a = world.gnss_antenna(name).unwrap_or_else(|e| bug(e));
        if self.gnss_plugged {
            self.gnss.update(now_ns, &mut self.uart, a.enu, a.velocity_enu);
        } else {
            // What the MCU sends reaches no receiver.
            self.uart.device_receive();
        }
        self.uart.advance_to(now_ns);
        let mut edge = self.gnss.pps_at(self.pps_seen_ns + 1);
        while edge <= now_ns {
            if self.gnss_plugged {
                if self.pps_us.len() == PPS_KEPT {
                    self.pps_us.pop_front();
                }
                self.pps_us.push_back(edge / 1000 - self.boot_us);
            }
            edge = self.gnss.pps_at(edge + 1);
        }
        self.pps_seen_ns = self.pps_seen_ns.max(now_ns);
    }

    /// The LSM6DSO on `IMU_CS`: a handle for `r2p_drivers::lsm6dso::Lsm6dso::new_spi`.
    pub fn lsm6dso_spi(&self) -> SimSpi {
        SimSpi::pluggable(self.lsm6dso.clone(), self.plugs[0].clone())
    }

    /// The LIS3MDL on SPI2 and `MAG_CS`: a handle for `r2p_drivers::lis3mdl::Lis3mdl::new_spi`.
    pub fn lis3mdl_spi(&self) -> SimSpi {
        SimSpi::pluggable(self.lis3mdl.clone(), self.plugs[1].clone())
    }

    /// The LPS22HH on `BARO_CS`: a handle for `r2p_drivers::lps22::Lps22::new_spi`.
    pub fn lps22hh_spi(&self) -> SimSpi {
        SimSpi::pluggable(self.lps22hh.clone(), self.plugs[2].clone())
    }

    /// USART1 as the MCU sees it: `embedded_io::{Read, ReadReady}` for the receiver's bytes as
    /// they have arrived by the last [`Self::advance`] (`Write` for commands to it, which the
    /// receiver model drops).
    pub fn gnss_uart(&mut self) -> &mut SimUart {
        &mut self.uart
    }

    /// The PPS rising edges since the last call, µs since boot, oldest first, at most the last
    /// eight: the instants TIM3_CH4's input capture latches (each at the top of a UTC second,
    /// while the receiver is plugged).
    pub fn take_pps_us(&mut self) -> Vec<Micros> {
        self.pps_us.drain(..).collect()
    }

    /// The register models, for tests and inspection (`peek`, `samples`).
    pub fn models(&self) -> (&Shared<Lsm6dsoModel>, &Shared<Lis3mdlModel>, &Shared<Lps22Model>) {
        (&self.lsm6dso, &self.lis3mdl, &self.lps22hh)
    }

    /// The receiver model (`epochs`).
    pub fn gnss(&self) -> &UbxGnssModel {
        &self.gnss
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal::spi::{Operation, SpiDevice};
    use embedded_io::Read;
    use embedded_io::Write;
    use r2p_drivers::{lis3mdl, lps22, lsm6dso, ubx};
    use r2p_world::magnetic::MagParams;
    use r2p_world::pressure::BaroParams;
    use r2p_world::{Pose, Robot};
    use ublox::proto23::{PacketRef, Proto23};
    use ublox::{GnssFixType, Parser, UbxPacket};

    const MS: Micros = 1000;

    /// robots/diffbot.toml (an IMU module called `imu` at the base's centre), with `extra`
    /// keys on its IMU module.
    fn diffbot(extra: &str) -> World {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/diffbot.toml");
        let text = std::fs::read_to_string(path).unwrap() + extra;
        World::from_robot(&Robot::parse(&text, "diffbot.toml").unwrap_or_else(|e| panic!("{e}")))
    }

    /// Steps the world and the rig to `t_us`, 1 ms at a time.
    fn run_to(w: &mut World, rig: &mut ImuSensors, t_us: Micros) {
        let mut now = w.time_ns() / 1000;
        while now < t_us {
            now += MS;
            w.advance_to_ns(now * 1000);
            rig.advance(now, w);
        }
    }

    /// Steps the world and the rig by `dt_us`.
    fn run_for(w: &mut World, rig: &mut ImuSensors, dt_us: Micros) {
        let t = w.time_ns() / 1000 + dt_us;
        run_to(w, rig, t);
    }

    /// One register over a raw SPI handle.
    fn read_reg(spi: &mut SimSpi, reg: u8) -> u8 {
        let mut b = [0];
        spi.transaction(&mut [Operation::Write(&[0x80 | reg]), Operation::Read(&mut b)]).unwrap();
        b[0]
    }

    #[test]
    fn each_part_answers_on_its_own_chip_select_with_the_worlds_readings() {
        let mut w = diffbot("");
        w.set_pose(Pose::new(0.0, 0.0, 0.6));
        let mut rig = ImuSensors::new(&w, "imu", 0, GnssLink::DEFAULT).unwrap();
        let mut imu = lsm6dso::Lsm6dso::new_spi(rig.lsm6dso_spi());
        let mut mag = lis3mdl::Lis3mdl::new_spi(rig.lis3mdl_spi());
        let mut baro = lps22::Lps22::new_spi(rig.lps22hh_spi());
        mag.init(lis3mdl::Config::default()).unwrap();
        // Configuring the magnetometer left the others in their power-up state.
        let (acc, _, bar) = rig.models();
        assert_eq!(acc.borrow().peek(0x10), 0, "LSM6DSO CTRL1_XL untouched");
        assert_eq!(bar.borrow().peek(0x10), 0, "LPS22HH CTRL_REG1 untouched");
        imu.init(lsm6dso::Config::default()).unwrap();
        assert_eq!(baro.init(lps22::Config::default()), Ok(Chip::Hh), "the board's part");
        let (mut fields, mut pressures) = (Vec::new(), Vec::new());
        for _ in 0..2000 {
            let t = w.time_ns() / 1000 + MS;
            run_to(&mut w, &mut rig, t);
            fields.extend(mag.read().unwrap().map(|s| s.field_ut));
            pressures.extend(baro.read().unwrap().map(|s| s.pressure_pa));
        }
        // 80 Hz and 25 Hz for 2 s.
        assert!((159..=160).contains(&fields.len()), "{} field samples", fields.len());
        assert!((49..=50).contains(&pressures.len()), "{} pressure samples", pressures.len());
        let m = w.imu_module("imu").unwrap();
        let want = m.magnetometer.expected(0.6);
        let n = fields.len() as f64;
        for (i, &b) in want.iter().enumerate() {
            let mean = fields.iter().map(|f| f64::from(f[i])).sum::<f64>() / n;
            // 5 standard errors of the noise, half an LSB (±4 gauss: 0.0146 µT), f32.
            let tol = 5.0 * MagParams::LIS3MDL.noise_ut[i] / n.sqrt() + 0.0073 + 1e-3;
            assert!((mean - b).abs() < tol, "axis {i}: {mean} vs {b}");
        }
        let p = m.barometer.expected(m.altitude_m);
        let mean = pressures.iter().map(|&x| f64::from(x)).sum::<f64>() / pressures.len() as f64;
        // f32 near 1e5 Pa: 0.008 Pa steps.
        let tol = 5.0 * BaroParams::LPS22HH.noise_pa / (pressures.len() as f64).sqrt() + 0.02;
        assert!((mean - p).abs() < tol, "{mean} vs {p}");
        assert!(imu.data_ready().unwrap().gyro, "the LSM6DSO samples as before");
    }

    #[test]
    fn an_unplugged_part_reads_0xff_the_others_carry_on_and_plugged_again_it_starts_afresh() {
        let mut w = diffbot("");
        let mut rig = ImuSensors::new(&w, "imu", 0, GnssLink::DEFAULT).unwrap();
        let mut mag = lis3mdl::Lis3mdl::new_spi(rig.lis3mdl_spi());
        let mut baro = lps22::Lps22::new_spi(rig.lps22hh_spi());
        mag.init(lis3mdl::Config::default()).unwrap();
        baro.init(lps22::Config::default()).unwrap();
        run_to(&mut w, &mut rig, 100 * MS);
        assert!(mag.read().unwrap().is_some());
        let samples = rig.models().1.borrow().samples();
        w.set_imu_sensor_connected("imu", ImuSensor::Magnetometer, false).unwrap();
        run_to(&mut w, &mut rig, 200 * MS);
        let mut spi = rig.lis3mdl_spi();
        assert_eq!(read_reg(&mut spi, 0x0F), 0xFF, "WHO_AM_I: MISO floats high");
        let e = mag.probe().unwrap_err();
        assert_eq!(e, lis3mdl::Error::WrongDevice { part: "LIS3MDL", found: 0xFF, expected: 0x3D });
        assert_eq!(rig.models().1.borrow().samples(), samples, "no sample while unplugged");
        // Writes reach nothing: the model keeps its configuration (continuous).
        spi.transaction(&mut [Operation::Write(&[0x22, 0x03])]).unwrap();
        assert_eq!(rig.models().1.borrow().peek(0x22), 0x00);
        // The barometer carries on.
        assert!(baro.read().unwrap().is_some());
        w.set_imu_sensor_connected("imu", ImuSensor::Magnetometer, true).unwrap();
        run_to(&mut w, &mut rig, 201 * MS);
        assert_eq!(read_reg(&mut spi, 0x0F), 0x3D);
        assert_eq!(read_reg(&mut spi, 0x22), 0x03, "power-up CTRL_REG3: powered down");
        assert_eq!(mag.read().unwrap(), None, "nothing until configured again");
        mag.init(lis3mdl::Config::default()).unwrap();
        run_to(&mut w, &mut rig, 215 * MS);
        assert!(mag.read().unwrap().is_some());
        // The LSM6DSO and the barometer the same way; a part unplugged in the robot file
        // reads 0xFF from the start.
        for (part, who, reg) in
            [(ImuSensor::AccelGyro, 0x6C, 0x0F), (ImuSensor::Barometer, 0xB3, 0x0F)]
        {
            let mut spi =
                if part == ImuSensor::AccelGyro { rig.lsm6dso_spi() } else { rig.lps22hh_spi() };
            assert_eq!(read_reg(&mut spi, reg), who);
            w.set_imu_sensor_connected("imu", part, false).unwrap();
            run_for(&mut w, &mut rig, MS);
            assert_eq!(read_reg(&mut spi, reg), 0xFF, "{part:?}");
        }
        let w = diffbot("unplugged = [\"barometer\"]\n");
        let rig = ImuSensors::new(&w, "imu", 0, GnssLink::DEFAULT).unwrap();
        let e = lps22::Lps22::new_spi(rig.lps22hh_spi()).probe().unwrap_err();
        assert_eq!(
            e,
            lps22::Error::WrongDevice { part: lps22::EITHER, found: 0xFF, expected: 0xB3 }
        );
        assert!(lis3mdl::Lis3mdl::new_spi(rig.lis3mdl_spi()).probe().is_ok());
    }

    /// A receiver configured in its flash for NAV-PVT at 5 Hz, at 115 200 baud.
    const PVT_5HZ: GnssLink = GnssLink {
        receiver: GnssSetup::Configured { rate_hz: 5 },
        mcu_baud: 115_200,
        ..GnssLink::DEFAULT
    };

    /// NAV-PVT epochs read from the rig's UART: (iTOW, fix type, lat, lon).
    fn nav_pvts(
        rig: &mut ImuSensors,
        parser: &mut Parser<Vec<u8>, Proto23>,
    ) -> Vec<(u32, GnssFixType, f64, f64)> {
        let mut buf = [0u8; 512];
        let n = rig.gnss_uart().read(&mut buf).unwrap_or(0);
        let mut out = Vec::new();
        let mut it = parser.consume_ubx(&buf[..n]);
        while let Some(p) = it.next() {
            if let Ok(UbxPacket::Proto23(PacketRef::NavPvt(p))) = p {
                out.push((p.itow(), p.fix_type(), p.latitude(), p.longitude()));
            }
        }
        out
    }

    #[test]
    fn the_receiver_sends_its_fixes_on_the_uart_and_its_pps_each_second_while_plugged() {
        let mut w = diffbot("");
        w.set_pose(Pose::new(2.0, -1.0, 0.0));
        // Booted at 0.5 s: PPS in µs since boot; the epochs before boot never reach the line.
        let mut first = ImuSensors::new(&w, "imu", 0, GnssLink::DEFAULT).unwrap();
        run_to(&mut w, &mut first, 500 * MS);
        let mut rig = ImuSensors::new(&w, "imu", 500 * MS, PVT_5HZ).unwrap();
        let mut parser = Parser::<_, Proto23>::new(Vec::new());
        run_to(&mut w, &mut rig, 501 * MS);
        assert!(nav_pvts(&mut rig, &mut parser).is_empty());
        assert_eq!(rig.gnss_uart().stats().received, 0, "nothing from before the boot");
        let mut epochs = Vec::new();
        let mut pps = Vec::new();
        for _ in 0..30_000 {
            let t = w.time_ns() / 1000 + MS;
            run_to(&mut w, &mut rig, t);
            epochs.extend(nav_pvts(&mut rig, &mut parser));
            pps.extend(rig.take_pps_us());
        }
        // 5 Hz from 0.6 s to 30.4 s (the last frame maybe still on the wire), no overrun.
        assert!((149..=150).contains(&epochs.len()), "{} epochs", epochs.len());
        assert_eq!(rig.gnss_uart().stats().overruns, 0);
        // iTOW of 2026-11-27 12:00:00.6 UTC: Friday, 12:00:18.6 GPS time = 475 218 600 ms.
        assert_eq!(epochs[0].0, 475_218_600);
        assert_eq!(epochs[0].1, GnssFixType::NoFix);
        let last = *epochs.last().unwrap();
        assert_eq!(last.1, GnssFixType::Fix3D);
        let o = w.site().origin();
        let fix = o.enu_to(&r2p_world::gnss::Geodetic {
            lat_deg: last.2,
            lon_deg: last.3,
            height_m: o.height_m,
        });
        let tol = 5.0 * r2p_world::gnss::GnssParams::UBLOX_M8.sigma_h_m; // 5 σ of its error
        assert!((fix[0] - 2.0).abs() < tol && (fix[1] + 1.0).abs() < tol, "{fix:?}");
        // An edge at each whole second of the world's time once the receiver, powered up cold
        // at the boot, has its fix (26 s later): 27 s … 30 s, µs since boot.
        let want: Vec<Micros> = (27..=30).map(|s| s * 1_000_000 - 500_000).collect();
        assert_eq!(pps, want);
        // Unplugged: the line goes quiet and the pulses stop; plugged again both come back.
        w.set_imu_sensor_connected("imu", ImuSensor::Gnss, false).unwrap();
        run_for(&mut w, &mut rig, 10 * MS);
        nav_pvts(&mut rig, &mut parser); // a frame already on the wire
        let received = rig.gnss_uart().stats().received;
        run_for(&mut w, &mut rig, 3000 * MS);
        assert_eq!(rig.gnss_uart().stats().received, received);
        assert!(rig.take_pps_us().is_empty());
        w.set_imu_sensor_connected("imu", ImuSensor::Gnss, true).unwrap();
        let mut again = 0;
        for _ in 0..1000 {
            run_for(&mut w, &mut rig, MS);
            again += nav_pvts(&mut rig, &mut parser).len();
        }
        assert_eq!(again, 5, "5 Hz");
        assert!(rig.take_pps_us().is_empty(), "cold again: no pulse before its fix");
        assert_eq!(rig.gnss_uart().stats().overruns, 0);
    }

    #[test]
    fn pps_edges_not_taken_are_kept_up_to_the_last_eight() {
        let mut w = diffbot("");
        let mut rig = ImuSensors::new(&w, "imu", 0, GnssLink::DEFAULT).unwrap();
        // The first edge with the fix, 26 s after power-up.
        run_for(&mut w, &mut rig, 28_500 * MS);
        assert_eq!(rig.take_pps_us(), [26_000_000, 27_000_000, 28_000_000]);
        assert!(rig.take_pps_us().is_empty(), "taken once");
        // A firmware that looks only every 12 s finds the last eight (a capture register would
        // hold the last one and its overcapture flag).
        run_for(&mut w, &mut rig, 12_000 * MS);
        let want: Vec<Micros> = (33..=40).map(|s| s * 1_000_000).collect();
        assert_eq!(rig.take_pps_us(), want);
    }

    #[test]
    fn the_same_seed_gives_the_same_bytes_and_registers() {
        let run = |seed: u64| {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../robots/diffbot.toml");
            let text = std::fs::read_to_string(path).unwrap();
            assert!(text.contains("seed = 2026"));
            let text = text.replace("seed = 2026", &format!("seed = {seed}"));
            let mut w = World::from_robot(&Robot::parse(&text, "diffbot.toml").unwrap());
            let mut rig = ImuSensors::new(&w, "imu", 0, PVT_5HZ).unwrap();
            let mut mag = lis3mdl::Lis3mdl::new_spi(rig.lis3mdl_spi());
            mag.init(lis3mdl::Config::default()).unwrap();
            let (mut field, mut line) = (Vec::new(), Vec::new());
            for _ in 0..28_000 {
                let t = w.time_ns() / 1000 + MS;
                run_to(&mut w, &mut rig, t);
                if let Some(s) = mag.read().unwrap() {
                    field.extend(s.field_ut.map(f32::to_bits));
                }
                let mut b = [0u8; 64];
                let n = rig.gnss_uart().read(&mut b).unwrap_or(0);
                line.extend_from_slice(&b[..n]);
            }
            (field, line)
        };
        let a = run(2026);
        assert_eq!(a, run(2026));
        let b = run(2027);
        assert_eq!(a.0.len(), b.0.len());
        assert_eq!(a.1.len(), b.1.len(), "the same frames at the same times");
        assert_ne!(a.0, b.0, "another device and noise");
        assert_ne!(a.1, b.1, "another receiver error once fixed");
    }

    /// Reads what the rig's UART has each millisecond for `ms` into `ubx`'s decoder; returns
    /// (NMEA RMC sentences seen, NAV-PVTs decoded).
    fn listen(
        w: &mut World,
        rig: &mut ImuSensors,
        dec: &mut ubx::Decoder,
        ms: u64,
    ) -> (usize, usize) {
        let (mut bytes, mut pvts) = (Vec::new(), 0);
        for _ in 0..ms {
            run_for(w, rig, MS);
            let mut buf = [0u8; 512];
            let n = rig.gnss_uart().read(&mut buf).unwrap_or(0);
            bytes.extend_from_slice(&buf[..n]);
            for &b in &buf[..n] {
                pvts += usize::from(matches!(dec.push(b), Some(ubx::Message::NavPvt(_))));
            }
        }
        (bytes.windows(6).filter(|w| w == b"$GNRMC").count(), pvts)
    }

    #[test]
    fn a_factory_receiver_is_configured_by_the_firmware_and_back_at_its_factory_settings_after_a_replug(
    ) {
        let mut w = diffbot("");
        let mut rig = ImuSensors::new(&w, "imu", 0, GnssLink::DEFAULT).unwrap();
        let mut dec = ubx::Decoder::default();
        // An M10 from the factory: NMEA (RMC first) once a second at 38 400 baud.
        let (rmc, pvts) = listen(&mut w, &mut rig, &mut dec, 2500);
        assert_eq!((rmc, pvts), (2, 0));
        // What the module does at boot (r2p_drivers::ubx): the configuration at each rate of
        // BOOT_BAUDS, then the operating rate.
        let boot = |w: &mut World, rig: &mut ImuSensors, dec: &mut ubx::Decoder| {
            let mut cfg = [0u8; ubx::BOOT_CONFIG_LEN];
            ubx::boot_config(5, &mut cfg).unwrap();
            for baud in ubx::BOOT_BAUDS {
                rig.gnss_uart().set_baud(baud);
                rig.gnss_uart().write_all(&cfg).unwrap();
                listen(w, rig, dec, 300);
            }
            rig.gnss_uart().set_baud(ubx::OPERATING_BAUD);
        };
        boot(&mut w, &mut rig, &mut dec);
        // 5 Hz for 2 s (the window's last frame maybe still on the wire).
        let (rmc, pvts) = listen(&mut w, &mut rig, &mut dec, 2000);
        assert!(rmc == 0 && (9..=10).contains(&pvts), "NAV-PVT alone: {rmc} RMC, {pvts} PVT");
        assert_eq!(rig.gnss().rate_hz(), 5.0);
        // Unplugged: what the firmware sends is lost; plugged again the receiver is back at its
        // factory settings and must be configured again.
        w.set_imu_sensor_connected("imu", ImuSensor::Gnss, false).unwrap();
        listen(&mut w, &mut rig, &mut dec, 20);
        rig.gnss_uart().write_all(&[0xB5, 0x62, 0x06, 0x8A]).unwrap();
        listen(&mut w, &mut rig, &mut dec, 1000);
        w.set_imu_sensor_connected("imu", ImuSensor::Gnss, true).unwrap();
        let (rmc, pvts) = listen(&mut w, &mut rig, &mut dec, 2500);
        assert_eq!((rmc, pvts), (2, 0));
        assert_eq!(rig.gnss().acks_naks(), (0, 0), "a fresh receiver, nothing heard");
        boot(&mut w, &mut rig, &mut dec);
        assert!((9..=10).contains(&listen(&mut w, &mut rig, &mut dec, 2000).1));
    }

    #[test]
    fn an_unknown_board_is_an_error_naming_it_and_the_time_of_week_follows_gps_time() {
        let w = diffbot("");
        let e = ImuSensors::new(&w, "imu2", 0, GnssLink::DEFAULT).err().unwrap();
        assert!(e.contains("no board `imu2`"), "{e}");
        let e = ImuSensors::new(&w, "left", 0, GnssLink::DEFAULT).err().unwrap();
        assert_eq!(e, "board `left`: is a motor board, not an imu board");
        // GPS week 0 began 1980-01-06 00:00:00 UTC; 18 leap seconds since.
        let at = |unix| GnssLink { start_unix_s: unix, ..GnssLink::DEFAULT }.start_tow_ms();
        assert_eq!(at(315_964_800), 18_000);
        assert_eq!(at(315_964_800 + 604_800 - 18), 0);
        assert_eq!(at(1_795_780_800), 475_218_000);
    }
}
