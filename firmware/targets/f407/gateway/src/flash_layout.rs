// Flash layout of the gateway image on the STM32F407VG (included by build.rs, for the linker
// check, and by main.rs).

/// Offset (from the start of flash) of the two sectors that keep the parameters: the last two
/// 128 KiB sectors (10 and 11) of the 1 MiB. The F407's sectors are 16, 64 and 128 KiB; the
/// parameter log erases one only when a sector's 16 384 records are used up, and an erase
/// stalls the CPU for 1–2 s (one bank), so it must be rare. The linker refuses an image that
/// reaches them (build.rs).
pub const PARAMS_BASE: u32 = 0x000C_0000;
