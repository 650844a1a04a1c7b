// Flash layout of an R2P module image on the STM32F103CB (included by the images' build.rs,
// for the linker check, and by module_core.rs).

/// Flash of the STM32F103CB, bytes.
pub const FLASH_SIZE: u32 = 128 * 1024;
/// Its erase page, bytes.
pub const PAGE_SIZE: u32 = 1024;
/// Offset (from the start of flash) of the two pages that keep the parameters: the last two.
/// The linker refuses an image that reaches them (build.rs).
pub const PARAMS_BASE: u32 = FLASH_SIZE - 2 * PAGE_SIZE;
