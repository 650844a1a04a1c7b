//! A robot file's `[modules.params]`, stored in a board's flash before its first boot.

use r2p_management::message::{ParamFault, Value};
use r2p_module::{FlashParams, ParamValues};
use r2p_node::{Param, ParamStore};
use r2p_world::kinematics::Layout;
use r2p_world::ranger::RangerKind;
use r2p_world::robot_file::{BaseController, Module, ParamValue, RangerMount, Robot, Wiring};
use r2p_world::BoardKind;

use super::chip::{ChipLayout, FlashError};
use super::BoardChip;
use crate::on_layout;

/// Stores `module`'s parameters from the robot file (and, for the gateway's base controller,
/// the robot's base and modules: [`base_values`]; whether it runs it: `[base] controller`) in
/// `flash`. Errors name the parameter and what is valid.
pub fn store_params(
    module: &Module,
    robot: &Robot,
    flash: &'static BoardChip,
) -> Result<(), String> {
    let mut values = module.params.clone();
    if module.kind() == BoardKind::Gateway {
        let index = robot.modules.iter().position(|m| m.name == module.name);
        let runs =
            matches!(robot.base_controller, Some(BaseController::Module(i)) if Some(i) == index);
        if !values.iter().any(|(n, _)| n == "base_controller") {
            values.push(("base_controller".into(), ParamValue::Bool(runs)));
        }
        if runs {
            values = base_values(robot, values);
        }
    }
    if let Wiring::Proximity { rangers } = &module.wiring {
        check_sensor_types(rangers, &values)
            .map_err(|e| format!("{} ({}): {e}", module.name, robot.file.display()))?;
    }
    let r = match module.kind() {
        BoardKind::Psu => store(r2p_app_psu::params::DEFAULTS, &values, flash),
        BoardKind::Proximity => store(r2p_app_proximity::params::DEFAULTS, &values, flash),
        BoardKind::Motor => store(r2p_app_motor::params::DEFAULTS, &values, flash),
        BoardKind::Gateway => store(super::gateway::PARAMS, &values, flash),
        BoardKind::Imu => store(r2p_app_imu::params::DEFAULTS, &values, flash),
        BoardKind::Template => store(r2p_app_template::params::DEFAULTS, &values, flash),
    };
    r.map_err(|e| format!("{} ({}): {e}", module.name, robot.file.display()))
}

/// The base controller's parameters follow the robot unless the file sets them: its geometry,
/// the proximity channels' directions, and the modules it talks to (each wheel's motor
/// controller and the proximity module, by their `instance` parameters).
pub fn base_values(
    robot: &Robot,
    mut values: Vec<(String, ParamValue)>,
) -> Vec<(String, ParamValue)> {
    let mut add = |name: &str, v: f64| {
        if !values.iter().any(|(n, _)| n == name) {
            values.push((name.into(), ParamValue::Float(v)));
        }
    };
    if let Layout::Omni { wheel_radius, wheel_distance, angles } = &robot.base.layout {
        add("wheel_radius_m", *wheel_radius);
        add("base_radius_m", *wheel_distance);
        add("first_wheel_deg", angles[0].to_degrees());
    }
    let mut instances = Vec::new();
    for m in &robot.modules {
        let instance = m.params.iter().find(|(n, _)| n == "instance").map_or(0, |(_, v)| match v {
            ParamValue::Int(i) => *i,
            _ => 0,
        });
        match &m.wiring {
            Wiring::Proximity { rangers } => {
                for r in rangers.iter().filter(|r| r.channel < 4) {
                    add(&format!("channel{}_deg", r.channel), r.mount.theta.to_degrees());
                }
                instances.push(("proximity_instance".to_string(), instance));
            }
            Wiring::Motor { wheel, .. } if *wheel < 3 => {
                instances.push((format!("wheel{wheel}_instance"), instance));
            }
            _ => {}
        }
    }
    for (name, instance) in instances {
        if !values.iter().any(|(n, _)| *n == name) {
            values.push((name, ParamValue::Int(instance)));
        }
    }
    values
}

/// The proximity firmware reads each channel with the curve its `sensorN` parameter names: a
/// ranger of another type would give wrong distances, so the robot file must agree.
fn check_sensor_types(
    rangers: &[RangerMount],
    values: &[(String, ParamValue)],
) -> Result<(), String> {
    for r in rangers.iter().filter(|r| r.channel < 4) {
        let want = match r.kind {
            RangerKind::Gp2y0a21 => 1,
            RangerKind::Gp2y0a02 => 2,
            RangerKind::MaxSonarLvEz => 3,
        };
        let key = format!("sensor{}", r.channel);
        let default = match r2p_app_proximity::params::DEFAULTS
            [usize::from(r2p_app_proximity::params::SENSOR0) + usize::from(r.channel)]
        .value
        {
            Value::U32(v) => i64::from(v),
            _ => 0,
        };
        let set = values.iter().find(|(n, _)| *n == key).map_or(default, |(_, v)| match v {
            ParamValue::Int(i) => *i,
            _ => -1,
        });
        if set != want {
            return Err(format!(
                "channel {} has a {} plugged in but the firmware's `{key}` is {set}: \
                 set {key} = {want} in the module's params",
                r.channel,
                r.kind.name()
            ));
        }
    }
    Ok(())
}

fn store<const N: usize>(
    defaults: [Param; N],
    values: &[(String, ParamValue)],
    flash: &'static BoardChip,
) -> Result<(), String> {
    // The parameter pages are the map's `params` partition, from its start.
    // Leaked, as a board's are: a store's table and values are `'static` (statics on the MCU).
    let table: &'static [Param; N] = Box::leak(Box::new(defaults));
    let params = FlashParams::new(table, Box::leak(Box::new(ParamValues::new())), 0);
    on_layout!(flash, load::<N>(&params, flash))
        .map_err(|e| format!("reading parameters: {e:?}"))?;
    set_values(&params, &defaults, values)?;
    on_layout!(flash, commit::<N>(&params, flash))
        .map_err(|e| format!("writing parameters: {e:?}"))?;
    Ok(())
}

/// Sets each of `values` by name in `params`, whose table is `defaults`.
pub fn set_values(
    params: &dyn ParamStore,
    defaults: &[Param],
    values: &[(String, ParamValue)],
) -> Result<(), String> {
    for (name, v) in values {
        let Some(i) = defaults.iter().position(|p| p.name == name) else {
            let known: Vec<&str> = defaults.iter().map(|p| p.name).collect();
            return Err(format!("no parameter `{name}`: the module has {}", known.join(", ")));
        };
        let p = defaults[i];
        let value = match (p.value, *v) {
            (Value::Bool(_), ParamValue::Bool(b)) => Value::Bool(b),
            (Value::U32(_), ParamValue::Int(n)) if n >= 0 && n <= i64::from(u32::MAX) => {
                Value::U32(n as u32)
            }
            (Value::I32(_), ParamValue::Int(n)) if i32::try_from(n).is_ok() => Value::I32(n as i32),
            (Value::F32(_), ParamValue::Float(f)) => Value::F32(f as f32),
            (Value::F32(_), ParamValue::Int(n)) => Value::F32(n as f32),
            _ => return Err(format!("`{name}` = {v:?}: expected {}", describe(&p))),
        };
        params.set(i as u16, value).map_err(|e| match e {
            ParamFault::OutOfRange => format!("`{name}` = {v:?} is out of range: {}", describe(&p)),
            other => format!("`{name}`: {other:?}"),
        })?;
    }
    Ok(())
}

fn load<L: ChipLayout, const N: usize>(
    params: &FlashParams<N>,
    flash: &'static BoardChip,
) -> Result<(), FlashError> {
    params.load(&mut L::params(flash)).map(|_| ())
}

fn commit<L: ChipLayout, const N: usize>(
    params: &FlashParams<N>,
    flash: &'static BoardChip,
) -> Result<(), FlashError> {
    params.commit(&mut L::params(flash)).map(|_| ())
}

fn describe(p: &Param) -> String {
    match (p.min, p.max) {
        (Value::U32(a), Value::U32(b)) => format!("an integer in {a}..={b}"),
        (Value::I32(a), Value::I32(b)) => format!("an integer in {a}..={b}"),
        (Value::F32(a), Value::F32(b)) => format!("a number in {a}..={b}"),
        _ => "true or false".into(),
    }
}
