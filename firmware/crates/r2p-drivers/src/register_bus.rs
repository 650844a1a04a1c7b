//! What a register-mapped sensor's driver needs of its bus — write one register, read a run of
//! consecutive ones — and what can go wrong: the same for every ST MEMS part the modules use
//! (LSM6DSO, LIS3MDL, LPS22HH/LPS22DF). Each driver implements the bus for I2C and SPI with its
//! chip's own rule for multi-byte access (an auto-increment bit in a control register, or in the
//! address byte).

use core::fmt;

/// Register access over some bus.
pub trait RegisterBus {
    /// The bus's error.
    type Error;
    /// The part is on SPI. Its chip select is high whenever another part on the bus is
    /// addressed, which to a part with its I2C interface on is I2C mode: it then reads the
    /// other parts' SCK and MOSI as SCL and SDA, and may take them for a START and its own
    /// address. ST's parts have a bit that turns I2C off; the drivers set it on SPI.
    const SPI: bool = false;
    /// Writes `value` to register `reg`.
    fn write_register(&mut self, reg: u8, value: u8) -> Result<(), Self::Error>;
    /// Reads `buf.len()` consecutive registers from `reg`.
    fn read_registers(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), Self::Error>;
}

/// What went wrong talking to a register-mapped sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error<E> {
    /// The bus failed (e.g. no acknowledge: nothing at that address).
    Bus(E),
    /// WHO_AM_I did not read the part's value: another chip, no chip (0xFF, 0x00), or the wrong
    /// I2C address or chip select.
    WrongDevice {
        /// The part the driver is for.
        part: &'static str,
        /// The value read.
        found: u8,
        /// The part's value.
        expected: u8,
    },
    /// A read came back all ones: nothing drove the data line (SPI's MISO or I2C's SDA idles
    /// high), so the part is unplugged or unpowered. A status register whose reserved bits read
    /// 0 cannot be 0xFF, so the drivers tell this from data.
    NotAnswering {
        /// The part the driver is for.
        part: &'static str,
    },
    /// A control register read back other than written (a bus or wiring fault).
    ConfigNotApplied {
        /// The part the driver is for.
        part: &'static str,
        /// The register.
        register: u8,
        /// Written.
        wrote: u8,
        /// Read back.
        read: u8,
    },
}

impl<E> From<E> for Error<E> {
    fn from(e: E) -> Self {
        Error::Bus(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Bus(e) => write!(f, "sensor bus error: {e:?}"),
            Error::WrongDevice { part, found, expected } => write!(
                f,
                "not an {part}: WHO_AM_I read {found:#04x}, expected {expected:#04x}; check the \
                 I2C address pin or the chip select"
            ),
            Error::NotAnswering { part } => write!(
                f,
                "the {part} does not answer: its read was all ones (unplugged or unpowered?)"
            ),
            Error::ConfigNotApplied { part, register, wrote, read } => write!(
                f,
                "{part} register {register:#04x} reads back {read:#04x} after writing \
                 {wrote:#04x}; check the bus wiring"
            ),
        }
    }
}

/// Reads WHO_AM_I (`register`) and checks it is the part's `value` (ST parts all have one).
pub(crate) fn probe<B: RegisterBus>(
    bus: &mut B,
    part: &'static str,
    register: u8,
    value: u8,
) -> Result<(), Error<B::Error>> {
    let mut id = [0];
    bus.read_registers(register, &mut id).map_err(Error::Bus)?;
    if id[0] != value {
        return Err(Error::WrongDevice { part, found: id[0], expected: value });
    }
    Ok(())
}

/// `Err(NotAnswering)` if every byte of a read is 0xFF (see [`Error::NotAnswering`]).
pub(crate) fn answered<E>(part: &'static str, bytes: &[u8]) -> Result<(), Error<E>> {
    if bytes.iter().all(|&b| b == 0xFF) {
        Err(Error::NotAnswering { part })
    } else {
        Ok(())
    }
}
