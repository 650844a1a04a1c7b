//! A simulated SPI device (a register device behind its chip select), implementing
//! [`embedded_hal::spi::SpiDevice`] as embedded-hal-bus's `ExclusiveDevice` over
//! embassy-stm32's SPI and a chip-select pin does on a module.
//!
//! Protocol (4-wire, the ST MEMS convention, e.g. LSM6DSO datasheet §6.2): a transaction is
//! one chip-select assertion. Full duplex: for every byte clocked out on MOSI one comes back
//! on MISO. The first byte is the command: bit 7 set = read, bits 6:0 the register address;
//! MISO is idle (0x00) during it. Then a read returns registers from the address on MISO
//! (MOSI ignored), a write stores MOSI bytes; the address advances by the device's rule
//! ([`RegisterDevice::next_register`]). With no device behind the chip select
//! ([`SimSpi::unconnected`]), or with its device unplugged ([`SimSpi::pluggable`], [`Plug`]:
//! a part that failed or came off, injected at run time) MISO floats high: every byte reads
//! 0xFF, and writes go nowhere.
//!
//! Not modelled: clock polarity/phase and speed (a transaction takes no virtual time),
//! 3-wire mode, the device's own address-space limits.

use std::cell::Cell;
use std::convert::Infallible;
use std::rc::Rc;

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use super::{RegisterDevice, Shared};

/// Bit 7 of the command byte: read.
pub const READ_BIT: u8 = 0x80;

enum State {
    Command,
    Read(u8),
    Write(u8),
}

/// Whether a device is on its bus: one switch shared by every handle of the device's bus and
/// whoever injects the fault (a board's sensor rig following the world's plugs).
#[derive(Clone, Debug)]
pub struct Plug(Rc<Cell<bool>>);

impl Plug {
    /// A plug, in or out.
    pub fn new(plugged: bool) -> Self {
        Self(Rc::new(Cell::new(plugged)))
    }

    /// Whether the device is on the bus.
    pub fn plugged(&self) -> bool {
        self.0.get()
    }

    /// Puts the device on the bus or takes it off.
    pub fn set(&self, plugged: bool) {
        self.0.set(plugged);
    }
}

/// A register device on its own chip select.
pub struct SimSpi {
    device: Option<Shared<dyn RegisterDevice>>,
    plug: Option<Plug>,
    transactions: u64,
}

impl SimSpi {
    /// `device` behind the chip select.
    pub fn new(device: Shared<dyn RegisterDevice>) -> Self {
        Self { device: Some(device), plug: None, transactions: 0 }
    }

    /// `device` behind the chip select while `plug` is in; nothing behind it while it is out.
    pub fn pluggable(device: Shared<dyn RegisterDevice>, plug: Plug) -> Self {
        Self { device: Some(device), plug: Some(plug), transactions: 0 }
    }

    /// A chip select with nothing behind it (MISO pulled high).
    pub fn unconnected() -> Self {
        Self { device: None, plug: None, transactions: 0 }
    }

    /// Transactions (chip-select assertions) so far.
    pub fn transactions(&self) -> u64 {
        self.transactions
    }
}

impl ErrorType for SimSpi {
    type Error = Infallible;
}

/// Clocks one byte: `mosi` in, the returned byte out.
fn shift(dev: &mut dyn RegisterDevice, state: &mut State, mosi: u8) -> u8 {
    match *state {
        State::Command => {
            let reg = dev.spi_address(mosi & !READ_BIT);
            *state = if mosi & READ_BIT != 0 { State::Read(reg) } else { State::Write(reg) };
            0x00
        }
        State::Read(reg) => {
            *state = State::Read(dev.next_register(reg));
            dev.read_register(reg)
        }
        State::Write(reg) => {
            dev.write_register(reg, mosi);
            *state = State::Write(dev.next_register(reg));
            0x00
        }
    }
}

impl SpiDevice for SimSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        self.transactions += 1;
        let unplugged = self.plug.as_ref().is_some_and(|p| !p.plugged());
        let Some(device) = self.device.as_ref().filter(|_| !unplugged) else {
            for op in operations {
                match op {
                    Operation::Read(b) | Operation::TransferInPlace(b) => b.fill(0xFF),
                    Operation::Transfer(r, _) => r.fill(0xFF),
                    Operation::Write(_) | Operation::DelayNs(_) => {}
                }
            }
            return Ok(());
        };
        let mut dev = device.borrow_mut();
        let mut state = State::Command;
        for op in operations {
            match op {
                Operation::Write(w) => {
                    for &b in w.iter() {
                        shift(&mut *dev, &mut state, b);
                    }
                }
                Operation::Read(r) => {
                    for b in r.iter_mut() {
                        *b = shift(&mut *dev, &mut state, 0x00);
                    }
                }
                Operation::Transfer(r, w) => {
                    // embedded-hal: clock max(len) bytes; words past `w` are 0x00 here,
                    // words past `r` are discarded.
                    for i in 0..r.len().max(w.len()) {
                        let out = shift(&mut *dev, &mut state, w.get(i).copied().unwrap_or(0));
                        if let Some(x) = r.get_mut(i) {
                            *x = out;
                        }
                    }
                }
                Operation::TransferInPlace(buf) => {
                    for b in buf.iter_mut() {
                        *b = shift(&mut *dev, &mut state, *b);
                    }
                }
                Operation::DelayNs(_) => {}
            }
        }
        Ok(())
    }
}
