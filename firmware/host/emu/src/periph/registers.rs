//! What the I2C and SPI models need of a device: a register file.

use std::cell::RefCell;
use std::rc::Rc;

/// A device handle shared by the bus model and whoever feeds the device.
pub type Shared<T> = Rc<RefCell<T>>;

/// Wraps `device` for sharing.
pub fn shared<T>(device: T) -> Shared<T> {
    Rc::new(RefCell::new(device))
}

/// A device whose bus protocol is "register address, then data": most I2C/SPI sensors.
pub trait RegisterDevice {
    /// Reads register `reg` (may have side effects, e.g. clearing a data-ready flag).
    fn read_register(&mut self, reg: u8) -> u8;
    /// Writes `value` to register `reg` (read-only registers ignore it).
    fn write_register(&mut self, reg: u8, value: u8);
    /// The register after `reg` in a multi-byte access: `reg + 1` with auto-increment on,
    /// `reg` itself with it off.
    fn next_register(&self, reg: u8) -> u8;
    /// The register an SPI command addresses, given the command less its read bit (7): bits
    /// 6:0 on most parts; parts with an increment bit there (ST's MS, bit 6) take it.
    fn spi_address(&mut self, command: u8) -> u8 {
        command
    }
    /// The register an I2C sub-address byte points at: the byte itself on most parts; parts
    /// that take their increment from its MSB take it.
    fn i2c_pointer(&mut self, sub_address: u8) -> u8 {
        sub_address
    }
}
