//! Parameters reached over the bus (PARAM_GET / PARAM_SET): typed values, checked by the store.

use core::cell::RefCell;

use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use r2p_management::message::{ParamFault, Value};

/// Where a module keeps its parameters. The node answers PARAM_GET and PARAM_SET through it.
///
/// The store decides what is valid: `set` checks the index, the value's type, writability and
/// range, and on any error changes nothing. Methods take `&self` (use interior mutability) so
/// the application can read its parameters while the node holds the store. `Sync`: the
/// application and the node (on the bus's interrupt executor) use it from two contexts.
pub trait ParamStore: Sync {
    /// The current value of parameter `index`.
    fn get(&self, index: u16) -> Result<Value, ParamFault>;
    /// Checks `value` and, if valid, applies it; returns the value now held.
    /// On error the old value stays.
    fn set(&self, index: u16, value: Value) -> Result<Value, ParamFault>;
}

/// A module without parameters: every index is unknown.
pub struct NoParams;

impl ParamStore for NoParams {
    fn get(&self, _index: u16) -> Result<Value, ParamFault> {
        Err(ParamFault::UnknownIndex)
    }
    fn set(&self, _index: u16, _value: Value) -> Result<Value, ParamFault> {
        Err(ParamFault::UnknownIndex)
    }
}

/// One parameter of a [`RamParams`]: its value, range and whether the bus may set it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Param {
    /// A name for tools and logs (not sent on the bus).
    pub name: &'static str,
    /// Current value; its variant is the parameter's type.
    pub value: Value,
    /// Smallest accepted value (same variant; ignored for `Bool`).
    pub min: Value,
    /// Largest accepted value (same variant; ignored for `Bool`).
    pub max: Value,
    /// Whether PARAM_SET may change it.
    pub writable: bool,
}

impl Param {
    /// A `u32` parameter in `min..=max`.
    pub const fn u32(name: &'static str, value: u32, min: u32, max: u32) -> Self {
        Self::new(name, Value::U32(value), Value::U32(min), Value::U32(max))
    }
    /// An `i32` parameter in `min..=max`.
    pub const fn i32(name: &'static str, value: i32, min: i32, max: i32) -> Self {
        Self::new(name, Value::I32(value), Value::I32(min), Value::I32(max))
    }
    /// An `f32` parameter in `min..=max` (NaN is always out of range).
    pub const fn f32(name: &'static str, value: f32, min: f32, max: f32) -> Self {
        Self::new(name, Value::F32(value), Value::F32(min), Value::F32(max))
    }
    /// A `bool` parameter.
    pub const fn bool(name: &'static str, value: bool) -> Self {
        Self::new(name, Value::Bool(value), Value::Bool(false), Value::Bool(true))
    }
    /// The same parameter, not settable over the bus.
    pub const fn read_only(mut self) -> Self {
        self.writable = false;
        self
    }

    const fn new(name: &'static str, value: Value, min: Value, max: Value) -> Self {
        Self { name, value, min, max, writable: true }
    }

    /// Whether `v` is acceptable for this parameter.
    pub fn check(&self, v: Value) -> Result<(), ParamFault> {
        let in_range = match (self.min, v, self.max) {
            (Value::Bool(_), Value::Bool(_), Value::Bool(_)) => true,
            (Value::U32(a), Value::U32(x), Value::U32(b)) => a <= x && x <= b,
            (Value::I32(a), Value::I32(x), Value::I32(b)) => a <= x && x <= b,
            // NaN compares false: out of range.
            (Value::F32(a), Value::F32(x), Value::F32(b)) => a <= x && x <= b,
            _ => return Err(ParamFault::WrongType),
        };
        if !self.writable {
            Err(ParamFault::ReadOnly)
        } else if in_range {
            Ok(())
        } else {
            Err(ParamFault::OutOfRange)
        }
    }
}

/// An application's view of its parameters: each read as its type, falling back to the
/// default in the module's parameter table when the store has no such index or holds another
/// type there (a store that lost its flash page must not stop the module: it runs on its
/// defaults), and to zero if the table disagrees too.
#[derive(Clone, Copy)]
pub struct Typed<'a> {
    store: &'a dyn ParamStore,
    defaults: &'a [Param],
}

impl<'a> Typed<'a> {
    /// `store`'s parameters, with `defaults` (index = position) to fall back on.
    pub fn new(store: &'a dyn ParamStore, defaults: &'a [Param]) -> Self {
        Self { store, defaults }
    }

    /// The table's default of parameter `index`, if the table has it. Inlined: with the table
    /// a constant and `index` one, it folds to the default's value.
    #[inline]
    fn default(&self, index: u16) -> Option<Value> {
        self.defaults.get(usize::from(index)).map(|p| p.value)
    }

    /// A `u32` parameter.
    #[inline]
    pub fn u32(&self, index: u16) -> u32 {
        let default = match self.default(index) {
            Some(Value::U32(v)) => v,
            _ => 0,
        };
        u32_or(self.store, index, default)
    }

    /// An `i32` parameter.
    #[inline]
    pub fn i32(&self, index: u16) -> i32 {
        let default = match self.default(index) {
            Some(Value::I32(v)) => v,
            _ => 0,
        };
        i32_or(self.store, index, default)
    }

    /// An `f32` parameter.
    #[inline]
    pub fn f32(&self, index: u16) -> f32 {
        let default = match self.default(index) {
            Some(Value::F32(v)) => v,
            _ => 0.0,
        };
        f32_or(self.store, index, default)
    }

    /// A `bool` parameter.
    #[inline]
    pub fn bool(&self, index: u16) -> bool {
        let default = match self.default(index) {
            Some(Value::Bool(v)) => v,
            _ => false,
        };
        bool_or(self.store, index, default)
    }
}

// The store's read, out of line and one per type: inlined into each of an application's reads
// (the PSU's step reads fifteen), each carried its own copy of the dyn call and the type check
// (~40 B); the default is folded at the call site, so no table is needed in flash.

/// `store`'s `u32` parameter `index`, or `default` if it has none of that type.
#[inline(never)]
fn u32_or(store: &dyn ParamStore, index: u16, default: u32) -> u32 {
    match store.get(index) {
        Ok(Value::U32(v)) => v,
        _ => default,
    }
}

/// `store`'s `i32` parameter `index`, or `default` if it has none of that type.
#[inline(never)]
fn i32_or(store: &dyn ParamStore, index: u16, default: i32) -> i32 {
    match store.get(index) {
        Ok(Value::I32(v)) => v,
        _ => default,
    }
}

/// `store`'s `f32` parameter `index`, or `default` if it has none of that type.
#[inline(never)]
fn f32_or(store: &dyn ParamStore, index: u16, default: f32) -> f32 {
    match store.get(index) {
        Ok(Value::F32(v)) => v,
        _ => default,
    }
}

/// `store`'s `bool` parameter `index`, or `default` if it has none of that type.
#[inline(never)]
fn bool_or(store: &dyn ParamStore, index: u16, default: bool) -> bool {
    match store.get(index) {
        Ok(Value::Bool(v)) => v,
        _ => default,
    }
}

/// `N` parameters in RAM, indexed 0..N (for tests and modules without persistence; flash
/// persistence wraps a store like this in the module firmware).
pub struct RamParams<const N: usize> {
    params: Mutex<CriticalSectionRawMutex, RefCell<[Param; N]>>,
}

impl<const N: usize> RamParams<N> {
    /// A store holding `params` (index = position).
    pub const fn new(params: [Param; N]) -> Self {
        Self { params: Mutex::new(RefCell::new(params)) }
    }

    /// Parameter `index`, as the application reads it.
    pub fn param(&self, index: u16) -> Option<Param> {
        self.params.lock(|p| p.borrow().get(usize::from(index)).copied())
    }
}

impl<const N: usize> ParamStore for RamParams<N> {
    fn get(&self, index: u16) -> Result<Value, ParamFault> {
        self.param(index).map(|p| p.value).ok_or(ParamFault::UnknownIndex)
    }

    fn set(&self, index: u16, value: Value) -> Result<Value, ParamFault> {
        self.params.lock(|p| {
            let mut p = p.borrow_mut();
            let param = p.get_mut(usize::from(index)).ok_or(ParamFault::UnknownIndex)?;
            param.check(value)?;
            param.value = value;
            Ok(value)
        })
    }
}

#[cfg(any(test, feature = "selftest"))]
pub(crate) mod tests {
    use super::*;

    r2p_testkit::suite! {
        fn ram_params_check_type_range_and_writability() {
            let p = RamParams::new([
                Param::u32("rate_hz", 100, 1, 1000),
                Param::f32("gain", 0.5, 0.0, 2.0),
                Param::i32("offset", 0, -10, 10).read_only(),
                Param::bool("enabled", true),
            ]);
            assert_eq!(p.get(0), Ok(Value::U32(100)));
            assert_eq!(p.set(0, Value::U32(1001)), Err(ParamFault::OutOfRange));
            assert_eq!(p.set(0, Value::I32(5)), Err(ParamFault::WrongType));
            assert_eq!(p.get(0), Ok(Value::U32(100)), "refused values are not applied");
            assert_eq!(p.set(0, Value::U32(1000)), Ok(Value::U32(1000)));
            assert_eq!(p.set(1, Value::F32(f32::NAN)), Err(ParamFault::OutOfRange));
            assert_eq!(p.set(1, Value::F32(-0.1)), Err(ParamFault::OutOfRange));
            assert_eq!(p.set(2, Value::I32(1)), Err(ParamFault::ReadOnly));
            assert_eq!(p.set(3, Value::Bool(false)), Ok(Value::Bool(false)));
            assert_eq!(p.get(4), Err(ParamFault::UnknownIndex));
            assert_eq!(p.set(4, Value::Bool(false)), Err(ParamFault::UnknownIndex));
            assert_eq!(NoParams.get(0), Err(ParamFault::UnknownIndex));
            assert_eq!(p.param(3).unwrap().name, "enabled");
        }

        fn every_type_accepts_both_bounds_and_refuses_one_step_past_them() {
            let p = RamParams::new([
                Param::u32("rate_hz", 100, 1, 1000),
                Param::i32("offset", 0, -10, 10),
                Param::f32("gain", 0.5, 0.0, 2.0),
            ]);
            for (i, lo, hi, below, above) in [
                (0, Value::U32(1), Value::U32(1000), Value::U32(0), Value::U32(1001)),
                (1, Value::I32(-10), Value::I32(10), Value::I32(-11), Value::I32(11)),
                (2, Value::F32(0.0), Value::F32(2.0), Value::F32(-1e-6), Value::F32(2.000_001)),
            ] {
                assert_eq!(p.set(i, lo), Ok(lo), "{i}: the minimum is allowed");
                assert_eq!(p.set(i, hi), Ok(hi), "{i}: the maximum is allowed");
                assert_eq!(p.set(i, below), Err(ParamFault::OutOfRange), "{i}");
                assert_eq!(p.set(i, above), Err(ParamFault::OutOfRange), "{i}");
                assert_eq!(p.get(i), Ok(hi), "{i}: a refused value is not applied");
            }
        }

        fn typed_reads_fall_back_to_the_table_then_to_zero() {
            const TABLE: [Param; 4] = [
                Param::u32("rate_hz", 100, 1, 1000),
                Param::f32("gain", 0.5, 0.0, 2.0),
                Param::i32("offset", -3, -10, 10),
                Param::bool("enabled", true),
            ];
            let store = RamParams::new(TABLE);
            let t = Typed::new(&store, &TABLE);
            assert_eq!((t.u32(0), t.f32(1), t.i32(2), t.bool(3)), (100, 0.5, -3, true));
            // The store's values, of every type, before the table's.
            store.set(0, Value::U32(50)).unwrap();
            store.set(1, Value::F32(1.5)).unwrap();
            store.set(2, Value::I32(7)).unwrap();
            store.set(3, Value::Bool(false)).unwrap();
            assert_eq!((t.u32(0), t.f32(1), t.i32(2), t.bool(3)), (50, 1.5, 7, false));
            // A store without the parameters (a lost flash page): the table's defaults.
            let t = Typed::new(&NoParams, &TABLE);
            assert_eq!((t.u32(0), t.f32(1), t.i32(2), t.bool(3)), (100, 0.5, -3, true));
            // Another type under the index (an old firmware's layout): the table's default.
            let other = RamParams::new([Param::f32("x", 9.0, 0.0, 10.0)]);
            assert_eq!(Typed::new(&other, &TABLE).u32(0), 100);
            // Neither has it: zero, never a panic.
            let t = Typed::new(&NoParams, &TABLE[..0]);
            assert_eq!((t.u32(7), t.f32(7), t.i32(7), t.bool(7)), (0, 0.0, 0, false));
        }
    }
}
