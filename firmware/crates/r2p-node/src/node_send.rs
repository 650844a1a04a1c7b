//! A [`Node`] is `Send`, checked by the compiler: a module builds its node in `main` and hands it
//! to the bus task on an interrupt executor, so everything the node holds must be safe to use
//! from another context. The `Sync` bounds on [`Export`](crate::Export),
//! [`Import`](crate::Import) and [`ParamStore`](crate::ParamStore) are what make it so; this
//! function (never called) stops the build if a field ever breaks it.

use crate::Node;

#[allow(dead_code)]
fn node_is_send<const E: usize, const I: usize, const T: usize, const R: usize, const B: usize>() {
    fn send<X: Send>() {}
    send::<Node<'static, E, I, T, R, B>>();
}
