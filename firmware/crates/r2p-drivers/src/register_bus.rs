//! What a register-mapped sensor's driver needs of its bus: write one register, read a run of
//! consecutive ones. Each driver implements it for I2C and SPI with its chip's own rule for
//! multi-byte access (an auto-increment bit in a control register, or in the address byte).

/// Register access over some bus.
pub trait RegisterBus {
    /// The bus's error.
    type Error;
    /// Writes `value` to register `reg`.
    fn write_register(&mut self, reg: u8, value: u8) -> Result<(), Self::Error>;
    /// Reads `buf.len()` consecutive registers from `reg`.
    fn read_registers(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), Self::Error>;
}
