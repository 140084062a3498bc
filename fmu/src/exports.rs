//! The 34 `extern "C"` functions of FMI 2.0 Co-Simulation. Every one goes through
//! [`call`] (null check, `catch_unwind`, error → `fmi2Error` with a logged message,
//! panic → `fmi2Fatal`); nothing else happens here.
//!
//! # Safety (all functions)
//! The importer must pass the pointers the FMI 2.0 standard prescribes: `c` a component
//! returned by `fmi2Instantiate` and not yet freed (NULL is detected), arrays valid for
//! the given lengths (NULL with length 0 is fine), strings NUL-terminated.

use crate::ffi::*;
use crate::model::Model;
use crate::slave::Snapshot;
use std::ffi::{c_char, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

/// One instance as handed to the importer.
struct Instance {
    name: CString,
    logger: Fmi2CallbackLogger,
    env: Fmi2ComponentEnvironment,
    debug: bool,
    slave: Model,
}

fn log_with(
    logger: Fmi2CallbackLogger,
    env: Fmi2ComponentEnvironment,
    name: &CStr,
    status: Fmi2Status,
    category: &str,
    msg: &str,
) {
    if let Some(f) = logger {
        let cat = CString::new(category).unwrap_or_default();
        let m = CString::new(msg.replace('\0', " ")).unwrap_or_default();
        // SAFETY: the logger is the importer's callback; every string is NUL-terminated
        // and outlives the call; "%s" consumes exactly one string argument.
        unsafe {
            f(
                env,
                name.as_ptr(),
                status,
                cat.as_ptr(),
                c"%s".as_ptr(),
                m.as_ptr(),
            )
        };
    }
}

impl Instance {
    fn log(&self, status: Fmi2Status, msg: &str) {
        let cat = match status {
            Fmi2Status::Ok => "logAll",
            Fmi2Status::Warning => "logStatusWarning",
            _ => "logStatusError",
        };
        if status != Fmi2Status::Ok || self.debug {
            log_with(self.logger, self.env, &self.name, status, cat, msg);
        }
    }
}

impl Instance {
    /// Logs the slave's pending warnings (a pose leaving the measured box): `fmi2Warning`
    /// when there were any, else `fmi2OK`.
    fn warn(&mut self) -> Fmi2Status {
        let w = self.slave.take_warnings();
        for m in &w {
            self.log(Fmi2Status::Warning, m);
        }
        if w.is_empty() {
            Fmi2Status::Ok
        } else {
            Fmi2Status::Warning
        }
    }
}

/// The trampoline: every exported function's body runs inside it.
fn call(
    c: Fmi2Component,
    what: &str,
    f: impl FnOnce(&mut Instance) -> Result<Fmi2Status, String>,
) -> Fmi2Status {
    if c.is_null() {
        return Fmi2Status::Error;
    }
    // SAFETY: non-null `c` was created by `fmi2Instantiate` (Box::into_raw) and is only
    // freed by `fmi2FreeInstance`; the importer does not call one instance concurrently.
    let inst = unsafe { &mut *(c as *mut Instance) };
    match catch_unwind(AssertUnwindSafe(|| f(inst))) {
        Ok(Ok(s)) => s,
        Ok(Err(msg)) => {
            inst.log(Fmi2Status::Error, &format!("{what}: {msg}"));
            Fmi2Status::Error
        }
        Err(_) => {
            inst.log(
                Fmi2Status::Fatal,
                &format!("{what}: internal error (panic)"),
            );
            Fmi2Status::Fatal
        }
    }
}

/// `(ptr, n)` → slice; NULL with `n == 0` → empty; NULL with `n > 0` → error.
///
/// # Safety
/// A non-null `p` must be valid for `n` reads.
unsafe fn slice<'a, T>(p: *const T, n: usize, what: &str) -> Result<&'a [T], String> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(format!("{what} is NULL but {n} values were announced"));
    }
    // SAFETY: non-null and valid for n elements per the caller's contract.
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// Mutable version of [`slice`].
///
/// # Safety
/// A non-null `p` must be valid for `n` writes.
unsafe fn slice_mut<'a, T>(p: *mut T, n: usize, what: &str) -> Result<&'a mut [T], String> {
    if n == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(format!("{what} is NULL but {n} values were announced"));
    }
    // SAFETY: non-null and valid for n elements per the caller's contract.
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// # Safety
/// `s` is NULL or NUL-terminated.
unsafe fn string(s: Fmi2String) -> Option<String> {
    if s.is_null() {
        return None;
    }
    // SAFETY: non-null, NUL-terminated per the caller's contract.
    Some(unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
}

fn percent_decode(s: &str) -> Result<String, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = s
                .get(i + 1..i + 3)
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("bad percent-encoding in '{s}'"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("resource location '{s}' is not UTF-8"))
}

/// The resources folder from `fmuResourceLocation` (`file:///p`, `file:/p`,
/// `file://localhost/p`, percent-encoded, with or without trailing slash, or a plain
/// path).
pub fn resource_dir(loc: &str) -> Result<PathBuf, String> {
    let rest = if let Some(r) = loc.strip_prefix("file://") {
        if let Some(r2) = r.strip_prefix("localhost") {
            r2.to_string()
        } else if r.starts_with('/') {
            r.to_string()
        } else {
            return Err(format!("resource location '{loc}' names a remote host"));
        }
    } else if let Some(r) = loc.strip_prefix("file:") {
        r.to_string()
    } else {
        loc.to_string()
    };
    let p = percent_decode(&rest)?;
    Ok(PathBuf::from(p.trim_end_matches('/').to_string() + "/"))
}

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
    Model::load(&resource_dir(&loc)?, name, guid)
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
    let res = catch_unwind(|| {
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
        match instantiate(&name, fmu_type, guid, loc) {
            Ok(slave) => {
                let inst = Box::new(Instance {
                    name: cname,
                    logger,
                    env,
                    debug: logging_on != 0,
                    slave,
                });
                Box::into_raw(inst) as Fmi2Component
            }
            Err(msg) => {
                log_with(
                    logger,
                    env,
                    &cname,
                    Fmi2Status::Error,
                    "logStatusError",
                    &format!("fmi2Instantiate: {msg}"),
                );
                std::ptr::null_mut()
            }
        }
    });
    res.unwrap_or(std::ptr::null_mut())
}

/// `fmi2FreeInstance`.
///
/// # Safety
/// See the module docs; `c` must not be used afterwards.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
    if !c.is_null() {
        // SAFETY: `c` came from Box::into_raw in fmi2Instantiate and is freed once.
        drop(unsafe { Box::from_raw(c as *mut Instance) });
    }
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
        Ok(Fmi2Status::Ok)
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
        i.slave.setup(start_time).map(|_| Fmi2Status::Ok)
    })
}

/// `fmi2EnterInitializationMode`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
    call(c, "fmi2EnterInitializationMode", |i| {
        i.slave.enter_init().map(|_| Fmi2Status::Ok)
    })
}

/// `fmi2ExitInitializationMode`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
    call(c, "fmi2ExitInitializationMode", |i| {
        i.slave.exit_init().map(|_| Fmi2Status::Ok)
    })
}

/// `fmi2Terminate`.
///
/// # Safety
/// See the module docs.
#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
    call(c, "fmi2Terminate", |i| {
        i.slave.terminate().map(|_| Fmi2Status::Ok)
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
        Ok(Fmi2Status::Ok)
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
        i.slave.set_real(vr, v).map(|_| Fmi2Status::Ok)
    })
}

fn no_such(kind: &str, nvr: usize) -> Result<Fmi2Status, String> {
    if nvr == 0 {
        Ok(Fmi2Status::Ok)
    } else {
        Err(format!("this FMU has no {kind} variables"))
    }
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
    call(c, "fmi2GetFMUstate", |i| {
        if state.is_null() {
            return Err("FMUstate pointer is NULL".into());
        }
        let snap = i.slave.snapshot()?;
        // SAFETY: `state` is a valid pointer to an fmi2FMUstate slot (checked non-null).
        let slot = unsafe { &mut *state };
        if slot.is_null() {
            *slot = Box::into_raw(Box::new(snap)) as Fmi2FmuState;
        } else {
            // SAFETY: a non-null slot holds a Snapshot this FMU allocated.
            unsafe { *(*slot as *mut Snapshot) = snap };
        }
        Ok(Fmi2Status::Ok)
    })
}

/// `fmi2SetFMUstate`.
///
/// # Safety
/// See the module docs; `state` was returned by `fmi2GetFMUstate` of this FMU.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    call(c, "fmi2SetFMUstate", |i| {
        if state.is_null() {
            return Err("FMUstate is NULL".into());
        }
        // SAFETY: a non-null state is a Snapshot this FMU allocated.
        let s = unsafe { &*(state as *const Snapshot) };
        i.slave.restore(s).map(|_| Fmi2Status::Ok)
    })
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
    call(c, "fmi2FreeFMUstate", |_| {
        if state.is_null() {
            return Ok(Fmi2Status::Ok);
        }
        // SAFETY: valid pointer to a state slot (checked non-null).
        let slot = unsafe { &mut *state };
        if !slot.is_null() {
            // SAFETY: the slot holds a Snapshot allocated by fmi2GetFMUstate; freed once.
            drop(unsafe { Box::from_raw(*slot as *mut Snapshot) });
            *slot = std::ptr::null_mut();
        }
        Ok(Fmi2Status::Ok)
    })
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
    call(c, "fmi2SerializedFMUstateSize", |_| {
        if state.is_null() || size.is_null() {
            return Err("FMUstate or size is NULL".into());
        }
        // SAFETY: a Snapshot of this FMU (non-null).
        let s = unsafe { &*(state as *const Snapshot) };
        // SAFETY: non-null out pointer.
        unsafe { *size = s.to_bytes().len() };
        Ok(Fmi2Status::Ok)
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
    call(c, "fmi2SerializeFMUstate", |_| {
        if state.is_null() {
            return Err("FMUstate is NULL".into());
        }
        // SAFETY: a Snapshot of this FMU (non-null).
        let s = unsafe { &*(state as *const Snapshot) };
        let b = s.to_bytes();
        if size < b.len() {
            return Err(format!(
                "buffer of {size} bytes is too small ({} needed)",
                b.len()
            ));
        }
        // SAFETY: buffer valid for `size` bytes (NULL detected).
        let out = unsafe { slice_mut(bytes as *mut u8, b.len(), "serializedState") }?;
        out.copy_from_slice(&b);
        Ok(Fmi2Status::Ok)
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
    call(c, "fmi2DeSerializeFMUstate", |_| {
        if state.is_null() {
            return Err("FMUstate pointer is NULL".into());
        }
        // SAFETY: buffer valid for `size` bytes (NULL detected).
        let b = unsafe { slice(bytes as *const u8, size, "serializedState") }?;
        let snap = Snapshot::from_bytes(b)?;
        // SAFETY: valid slot pointer (checked non-null).
        let slot = unsafe { &mut *state };
        if !slot.is_null() {
            // SAFETY: a non-null slot holds a Snapshot of this FMU; replaced.
            drop(unsafe { Box::from_raw(*slot as *mut Snapshot) });
        }
        *slot = Box::into_raw(Box::new(snap)) as Fmi2FmuState;
        Ok(Fmi2Status::Ok)
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
        Ok(Fmi2Status::Ok)
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
        Ok(Fmi2Status::Ok)
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
