//! The module image's build steps (../module-core/build_image.rs) for its board file.

include!("../module-core/build_image.rs");

fn main() {
    build_image("../../../boards/imu.toml", Link::FlashBase);
}
