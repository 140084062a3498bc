//! The 34 `extern "C"` functions of FMI 2.0 Co-Simulation. Every one goes through
//! [`call`] (null check, refusal after a panic, `catch_unwind`, error → `fmi2Error` with a
//! logged message, panic → `fmi2Fatal`); nothing else happens here.
//!
//! # Safety (all functions)
//! The importer must pass the pointers the FMI 2.0 standard prescribes: `c` a component
//! returned by `fmi2Instantiate` and not yet freed (NULL is detected), arrays valid for
//! the given lengths (NULL with length 0 is fine), strings NUL-terminated.

use crate::ffi::*;
use crate::model::Model;
use crate::trampoline::{
    call, deserialize_state, free, free_state, get_state, guard, into_raw, load_slave, no_such,
    resource_dir, serialize_state, set_state, slice, slice_mut, state_size, string, Api, Instance,
    Logger, Status,
};
use std::ffi::{c_char, CString};

fn instantiate(
    name: &str,
    ty: Fmi2Type,
    guid: Option<String>,
    loc: Option<String>,
) -> Result<Model, String> {
    if ty != 1 {
        return Err(
            "this FMU supports Co-Simulation only (fmuType must be fmi2CoSimulation)".into(),
        );
    }
    let loc = loc.ok_or("fmuResourceLocation is NULL")?;
    load_slave(Api::Fmi2, name, guid, resource_dir(&loc)?)
}

/// `fmi2GetTypesPlatform`.
#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

/// `fmi2GetVersion`.
#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

/// `fmi2Instantiate`. Returns NULL (after logging why) on any problem.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: Fmi2String,
    fmu_type: Fmi2Type,
    fmu_guid: Fmi2String,
    fmu_resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    guard(std::ptr::null_mut(), || {
        // SAFETY: strings are NULL or NUL-terminated (module contract).
        let name = unsafe { string(instance_name) }.unwrap_or_else(|| "mtwin".into());
        // SAFETY: as above.
        let guid = unsafe { string(fmu_guid) };
        // SAFETY: as above.
        let loc = unsafe { string(fmu_resource_location) };
        let (logger, env) = if functions.is_null() {
            (None, std::ptr::null_mut())
        } else {
            // SAFETY: non-null callback struct from the importer, valid during the call.
            let f = unsafe { &*functions };
            (f.logger, f.component_environment)
        };
        let cname = CString::new(name.replace('\0', " ")).unwrap_or_default();
        let logger = Logger::Fmi2(logger, env);
        match instantiate(&name, fmu_type, guid, loc) {
            Ok(slave) => into_raw(Instance::new(cname, logger, logging_on != 0, slave)),
            Err(msg) => {
                logger.log(
                    &cname,
                    Status::Error,
                    "logStatusError",
                    &format!("fmi2Instantiate: {msg}"),
                );
                std::ptr::null_mut()
            }
        }
    })
}

/// `fmi2FreeInstance`.
///
/// # Safety
/// See the module docs; `c` must not be used afterwards.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
    // SAFETY: `c` is NULL or came from fmi2Instantiate and is freed once (module docs).
    unsafe { free(c) };
}

/// `fmi2SetDebugLogging`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    _n: usize,
    _categories: *const Fmi2String,
) -> Fmi2Status {
    call(c, "fmi2SetDebugLogging", |i| {
        i.debug = logging_on != 0;
        Ok(Status::Ok)
    })
}

/// `fmi2SetupExperiment`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Fmi2Component,
    _tolerance_defined: Fmi2Boolean,
    _tolerance: Fmi2Real,
    start_time: Fmi2Real,
    _stop_time_defined: Fmi2Boolean,
    _stop_time: Fmi2Real,
) -> Fmi2Status {
    call(c, "fmi2SetupExperiment", |i| {
        i.slave.setup(start_time).map(|_| Status::Ok)
    })
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
    call(c, "fmi2EnterInitializationMode", |i| {
        i.slave.enter_init().map(|_| Status::Ok)
    })
}

/// `fmi2ExitInitializationMode`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
    call(c, "fmi2ExitInitializationMode", |i| {
        i.slave.exit_init().map(|_| Status::Ok)
    })
}

/// `fmi2Terminate`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
    call(c, "fmi2Terminate", |i| {
        i.slave.terminate().map(|_| Status::Ok)
    })
}

/// `fmi2Reset`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
    call(c, "fmi2Reset", |i| {
        i.slave.reset();
        Ok(Status::Ok)
    })
}

/// `fmi2GetReal`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    call(c, "fmi2GetReal", |i| {
        // SAFETY: arrays valid for nvr elements (module contract; NULL detected).
        let vr = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: as above.
        let out = unsafe { slice_mut(value, nvr, "value") }?;
        i.slave.get_real(vr, out)?;
        Ok(i.warn())
    })
}

/// `fmi2SetReal`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Real,
) -> Fmi2Status {
    call(c, "fmi2SetReal", |i| {
        // SAFETY: arrays valid for nvr elements (module contract; NULL detected).
        let vr = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: as above.
        let v = unsafe { slice(value, nvr, "value") }?;
        i.slave.set_real(vr, v).map(|_| Status::Ok)
    })
}

/// `fmi2GetInteger` (no integer variables).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *mut Fmi2Integer,
) -> Fmi2Status {
    call(c, "fmi2GetInteger", |_| no_such("integer", nvr))
}

/// `fmi2GetBoolean` (no boolean variables).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *mut Fmi2Boolean,
) -> Fmi2Status {
    call(c, "fmi2GetBoolean", |_| no_such("boolean", nvr))
}

/// `fmi2GetString` (no string variables).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    call(c, "fmi2GetString", |_| no_such("string", nvr))
}

/// `fmi2SetInteger` (no integer variables).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *const Fmi2Integer,
) -> Fmi2Status {
    call(c, "fmi2SetInteger", |_| no_such("integer", nvr))
}

/// `fmi2SetBoolean` (no boolean variables).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *const Fmi2Boolean,
) -> Fmi2Status {
    call(c, "fmi2SetBoolean", |_| no_such("boolean", nvr))
}

/// `fmi2SetString` (no string variables).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *const Fmi2String,
) -> Fmi2Status {
    call(c, "fmi2SetString", |_| no_such("string", nvr))
}

/// `fmi2GetFMUstate`.
///
/// # Safety
/// See the module docs; `state` points to NULL or to a state from this FMU.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    // SAFETY: `state` as the standard prescribes (module docs; NULL detected).
    call(c, "fmi2GetFMUstate", |i| unsafe { get_state(i, state) })
}

/// `fmi2SetFMUstate`.
///
/// # Safety
/// See the module docs; `state` was returned by `fmi2GetFMUstate` of this FMU.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    // SAFETY: `state` NULL or from fmi2GetFMUstate of this FMU (module docs).
    call(c, "fmi2SetFMUstate", |i| unsafe { set_state(i, state) })
}

/// `fmi2FreeFMUstate`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(
    c: Fmi2Component,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    // SAFETY: `state` as the standard prescribes (module docs; NULL detected).
    call(c, "fmi2FreeFMUstate", |_| unsafe { free_state(state) })
}

/// `fmi2SerializedFMUstateSize`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    // SAFETY: `state` of this FMU, `size` writable (module docs; NULL detected).
    call(c, "fmi2SerializedFMUstateSize", |_| unsafe {
        state_size(state, size)
    })
}

/// `fmi2SerializeFMUstate`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Fmi2Component,
    state: Fmi2FmuState,
    bytes: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    // SAFETY: `state` of this FMU, `bytes` valid for `size` (module docs; NULL detected).
    call(c, "fmi2SerializeFMUstate", |_| unsafe {
        serialize_state(state, bytes as *mut u8, size)
    })
}

/// `fmi2DeSerializeFMUstate`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Fmi2Component,
    bytes: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    // SAFETY: `bytes` valid for `size`, `state` a slot (module docs; NULL detected).
    call(c, "fmi2DeSerializeFMUstate", |_| unsafe {
        deserialize_state(bytes as *const u8, size, state)
    })
}

/// `fmi2GetDirectionalDerivative` (not provided).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Fmi2Component,
    _u: *const Fmi2ValueReference,
    _nu: usize,
    _k: *const Fmi2ValueReference,
    _nk: usize,
    _dk: *const Fmi2Real,
    _du: *mut Fmi2Real,
) -> Fmi2Status {
    call(c, "fmi2GetDirectionalDerivative", |_| {
        Err("not provided (providesDirectionalDerivative is false)".into())
    })
}

/// `fmi2SetRealInputDerivatives` (not supported).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *const Fmi2Real,
) -> Fmi2Status {
    call(c, "fmi2SetRealInputDerivatives", |_| {
        Err("not supported (canInterpolateInputs is false)".into())
    })
}

/// `fmi2GetRealOutputDerivatives` (not supported).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *mut Fmi2Real,
) -> Fmi2Status {
    call(c, "fmi2GetRealOutputDerivatives", |_| {
        Err("not supported (maxOutputDerivativeOrder is 0)".into())
    })
}

/// `fmi2DoStep`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: Fmi2Component,
    t: Fmi2Real,
    h: Fmi2Real,
    _no_set_prior: Fmi2Boolean,
) -> Fmi2Status {
    call(c, "fmi2DoStep", |i| {
        i.slave.do_step(t, h)?;
        Ok(i.warn())
    })
}

/// `fmi2CancelStep` (steps are synchronous).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
    call(c, "fmi2CancelStep", |_| {
        Err("no asynchronous step is pending (doStep never returns fmi2Pending)".into())
    })
}

/// `fmi2GetStatus`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(
    c: Fmi2Component,
    _kind: Fmi2StatusKind,
    _value: *mut Fmi2Status,
) -> Fmi2Status {
    call(c, "fmi2GetStatus", |_| {
        Err("no asynchronous step is pending (doStep never returns fmi2Pending)".into())
    })
}

/// `fmi2GetRealStatus` (`fmi2LastSuccessfulTime`).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    call(c, "fmi2GetRealStatus", |i| {
        if kind != 2 {
            return Err(format!(
                "status kind {kind} has no real value (only fmi2LastSuccessfulTime)"
            ));
        }
        if value.is_null() {
            return Err("value is NULL".into());
        }
        // SAFETY: non-null out pointer.
        unsafe { *value = i.slave.time() };
        Ok(Status::Ok)
    })
}

/// `fmi2GetIntegerStatus` (none).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    _value: *mut Fmi2Integer,
) -> Fmi2Status {
    call(c, "fmi2GetIntegerStatus", |_| {
        Err(format!("status kind {kind} has no integer value"))
    })
}

/// `fmi2GetBooleanStatus` (`fmi2Terminated`: always false).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    call(c, "fmi2GetBooleanStatus", |_| {
        if kind != 3 {
            return Err(format!(
                "status kind {kind} has no boolean value (only fmi2Terminated)"
            ));
        }
        if value.is_null() {
            return Err("value is NULL".into());
        }
        // SAFETY: non-null out pointer.
        unsafe { *value = 0 };
        Ok(Status::Ok)
    })
}

/// `fmi2GetStringStatus` (none).
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    call(c, "fmi2GetStringStatus", |_| {
        Err(format!("status kind {kind} has no string value"))
    })
}
