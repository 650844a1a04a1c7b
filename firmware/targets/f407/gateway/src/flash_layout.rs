// Flash layout of the gateway image on the STM32F407VG (included by build.rs, for the linker
// check, and by main.rs).

/// Offset (from the start of flash) of the two sectors that keep the parameters: the last two
/// 128 KiB sectors (10 and 11) of the 1 MiB. The image is linked at the flash base
/// (images.toml's `image_origin`), so it covers sectors 2–3, where the bootloader's flash map
/// puts the parameters (`[mcu.STM32F407VG.partitions] params`): those become the gateway's once
/// its image moves behind the F407 bootloader (to `active`). Until then sectors 10–11, in the
/// map's DFU partition, which nothing uses without the bootloader. A 128 KiB sector holds
/// 16 384 parameter records, so the log erases one only then — but the first write of a
/// parameter erases one too, which stalls the CPU (one bank) for 1–2 s. The linker refuses an
/// image that reaches them (build.rs).
pub const PARAMS_BASE: u32 = 0x000C_0000;
