//! A simulated I2C controller with register devices on it, implementing
//! [`embedded_hal::i2c::I2c`] as embassy-stm32's I2C driver does on a module.
//!
//! Protocol (7-bit addressing, as the NXP I2C specification UM10204 and sensor datasheets
//! describe it): a transaction starts with START + address; an address no device answers is
//! not acknowledged and the transaction fails with `NoAcknowledge(Address)` before any byte
//! moves. After START + address + W, the first byte is the device's register pointer and the
//! following bytes are written from there; after a repeated START + address + R, bytes are
//! read from the pointer. The pointer advances after every data byte by the device's rule
//! ([`RegisterDevice::next_register`]: auto-increment, or not). Adjacent operations of the
//! same kind are one phase (no repeated START), as embedded-hal specifies; a read with no
//! pointer written reads on from where the last access left it.
//!
//! Not modelled: bus timing (a transaction takes no virtual time), clock stretching,
//! arbitration between controllers, 10-bit addresses, data NACKs from the device.

use std::fmt;

use embedded_hal::i2c::{ErrorKind, ErrorType, I2c, NoAcknowledgeSource, Operation};

use super::{RegisterDevice, Shared};

/// Why a transaction failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum I2cError {
    /// No device acknowledged this address.
    NoDevice {
        /// The 7-bit address.
        address: u8,
    },
}

impl fmt::Display for I2cError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            I2cError::NoDevice { address } => {
                write!(f, "no I2C device acknowledged address {address:#04x}")
            }
        }
    }
}

impl std::error::Error for I2cError {}

impl embedded_hal::i2c::Error for I2cError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address)
    }
}

struct Target {
    address: u8,
    device: Shared<dyn RegisterDevice>,
    pointer: u8,
}

/// The bus: a controller and the devices wired to it.
#[derive(Default)]
pub struct SimI2c {
    targets: Vec<Target>,
    transactions: u64,
    nacks: u64,
}

impl SimI2c {
    /// An empty bus.
    pub fn new() -> Self {
        Self::default()
    }

    /// Wires `device` at 7-bit `address` (panics if taken: two devices on one address is a
    /// wiring mistake in the test or robot, not a bus condition).
    pub fn attach(&mut self, address: u8, device: Shared<dyn RegisterDevice>) {
        assert!(address < 0x80, "I2C address {address:#x} is not 7-bit");
        assert!(
            self.targets.iter().all(|t| t.address != address),
            "two devices at I2C address {address:#04x}"
        );
        self.targets.push(Target { address, device, pointer: 0 });
    }

    /// Transactions run, including failed ones.
    pub fn transactions(&self) -> u64 {
        self.transactions
    }

    /// Transactions no device acknowledged.
    pub fn nacks(&self) -> u64 {
        self.nacks
    }
}

impl ErrorType for SimI2c {
    type Error = I2cError;
}

impl I2c for SimI2c {
    fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), I2cError> {
        self.transactions += 1;
        let Some(t) = self.targets.iter_mut().find(|t| t.address == address) else {
            self.nacks += 1;
            return Err(I2cError::NoDevice { address });
        };
        let mut dev = t.device.borrow_mut();
        let mut previous_was_write = None;
        for op in operations {
            match op {
                Operation::Write(bytes) => {
                    // A new write phase (START or repeated START) begins with the pointer.
                    let mut data = bytes.iter();
                    if previous_was_write != Some(true) {
                        if let Some(&p) = data.next() {
                            t.pointer = dev.i2c_pointer(p);
                        }
                    }
                    for &b in data {
                        dev.write_register(t.pointer, b);
                        t.pointer = dev.next_register(t.pointer);
                    }
                    previous_was_write = Some(true);
                }
                Operation::Read(buf) => {
                    for b in buf.iter_mut() {
                        *b = dev.read_register(t.pointer);
                        t.pointer = dev.next_register(t.pointer);
                    }
                    previous_was_write = Some(false);
                }
            }
        }
        Ok(())
    }
}
